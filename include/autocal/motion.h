// The parts every robot-driving stage is built from, beside the encoders (sensors.h
// EncoderTracker): when a stop has settled, when the current motion started, how a wheel's duty
// follows a pulse rate, and when a driven wheel has stalled. No ROS.
#pragma once

#include <string>
#include <vector>

#include "autocal/sensors.h"

namespace autocal {

/// When a stop has settled: `settle_s` after the stop at least, then a reading with the encoders
/// still for `still_s`, or `max_settle_s` after the stop whatever they say (a wheel that creeps
/// on must not hold the run).
struct SettleRule {
  double settle_s = 0.0;      ///< [s]
  double still_s = 0.0;       ///< [s]
  double max_settle_s = 0.0;  ///< [s]

  bool settled(double stop_s, double now_s, const EncoderTracker& encoders) const {
    if (now_s < stop_s + settle_s) return false;
    if (now_s >= stop_s + max_settle_s) return true;
    return encoders.stillSince(stop_s, still_s);
  }
};

/// When the current motion started: at the first update that drives it, not when it was decided
/// (a stage may decide a motion in a callback and drive it from the next update).
class MotionClock {
 public:
  /// A motion decided at `now_s`: its clock starts at the next start(); until then startS() is
  /// `now_s`.
  void reset(double now_s) {
    started_ = false;
    start_s_ = now_s;
  }
  /// Starts the clock at `now_s` unless it runs; true when it started now.
  bool start(double now_s) {
    if (started_) return false;
    started_ = true;
    start_s_ = now_s;
    return true;
  }
  bool started() const { return started_; }
  double startS() const { return start_s_; }  ///< [s]
  double elapsedS(double now_s) const { return now_s - start_s_; }

 private:
  bool started_ = true;
  double start_s_ = 0.0;
};

/// The checks at the top of every update of a run that drives on its encoders alone (UahRun,
/// UmbmarkRun): the run's clock from its first update, each update's time step, and the failures
/// of time and encoders.
class RunWatch {
 public:
  /// The update at `now_s`: the run's clock starts at the first. Returns the time since the
  /// previous update [s], clamped to 0..`max_step_s` (a stalled caller must not make one huge
  /// control step).
  double tick(double now_s, double max_step_s = 0.2);
  bool started() const { return started_; }
  /// Time since the first update, at the last one [s]; 0 before it.
  double elapsedS() const { return started_ ? last_s_ - start_s_ : 0.0; }
  /// The last update's time [s].
  double lastS() const { return last_s_; }

  /// An encoder reading arrived (whatever its stamp).
  void noteEncoders() { updates_without_encoders_ = 0; }

  /// Why the run must fail at `now_s`, or empty: it ran longer than `max_duration_s` (> 0; "the
  /// <what> took longer than max_duration_s (T s) in <where>"), no encoder reading came within
  /// `encoder_timeout_s` of its start ("no encoder readings"), or, while `moving`, none came for
  /// `encoder_timeout_s` ("the encoders went silent for T s"). Silence is also more than
  /// kSilentUpdates updates without a reading: a node that was not scheduled for a while (or a
  /// simulator that ran on before the first command) sees one long gap, then the readings that
  /// came meanwhile.
  std::string failure(double now_s, const EncoderTracker& encoders, bool moving,
                      double max_duration_s, double encoder_timeout_s, const std::string& what,
                      const std::string& where) const;

  static constexpr int kSilentUpdates = 10;

 private:
  bool started_ = false;
  double start_s_ = 0.0, last_s_ = 0.0;
  int updates_without_encoders_ = 0;
};

/// A wheel's duty magnitude after `dt_s` of integral control on its pulse-rate error: the robot's
/// deadbands and motor gains are unknown to the stage. Clamped to 0..max_duty.
double followRate(double duty, double measured_rate, double target_rate, double gain_per_s,
                  double dt_s, double max_duty);

/// A driven wheel's stall: the encoder of `side` (0 left, 1 right) has not changed for more than
/// `stall_s` since the later of its last change and the motion's start. Returns "the left wheel has
/// not moved for T s at duty D (the robot stalled: blocked, or a motor fault)", or empty.
std::string stallOf(int side, const EncoderTracker& encoders, const MotionClock& motion,
                    double now_s, double stall_s, double duty);

/// The options of a run that drives on its encoders alone (UahRun, UmbmarkRun derive theirs from
/// it): how a wheel's duty follows a pulse rate, the encoder checks, the stall and the settling.
struct EncoderDriveOptions {
  /// Duty a rate-controlled wheel starts at, and the largest it may reach [1].
  double start_duty = 0.15;
  double max_duty = 0.7;
  /// How fast a wheel's duty follows its pulse-rate error [duty/s at 100 % rate error].
  double rate_gain_per_s = 0.3;
  /// Encoder sanity: a wheel that moved faster than this between two readings (over at least
  /// encoder_jump_window_s, since the two wheels' messages arrive apart) was reset or jumped
  /// [pulses/s] (plus a few pulses of slack). A Duckiebot's wheel at full duty: ~600 pulses/s.
  double max_encoder_rate_pulses_per_s = 1500.0;
  double encoder_jump_window_s = 0.1;
  /// A driven wheel whose encoder has not moved for this long has stalled [s].
  double stall_s = 3.0;
  /// After a stop: wait until the encoders have been still this long, and at least settle_s [s].
  double still_s = 0.2;
  double settle_s = 0.4;
  /// Silence of the encoders (while moving) that fails the run [s].
  double encoder_timeout_s = 2.0;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// The wheels of a run that drives on its encoders alone: the encoders with their jump check, the
/// run's clock, the current motion's clock and encoder samples, each wheel's duty following a
/// pulse rate with its stall check, and the stop with its settling. The run keeps its own state
/// machine and says what each motion is.
class EncoderDrive {
 public:
  /// Unwrapped counts at one stamp.
  struct Sample {
    double stamp_s = 0.0;
    double left = 0.0, right = 0.0;
  };

  /// `max_settle_s`: a stop has settled this long after it whatever the encoders say.
  EncoderDrive(const EncoderDriveOptions& options, double max_settle_s);

  /// A reading (EncoderTracker::add). Returns why its counts cannot be trusted (a reset or a
  /// jump), or empty; `step` gets what it added.
  std::string add(double stamp_s, int left_ticks, int right_ticks, EncoderTracker::Step* step);
  /// Keeps the counts now as the motion's newest sample. The two wheels' messages arrive one after
  /// the other with the same stamp (the driver reads both at once): the second completes the
  /// first's sample instead of adding a half-updated one (a pulse rate's worth of false heading).
  void keepSample();
  /// Drops samples more than `keep_s` older than the newest (two stay at least).
  void forgetOlderThan(double keep_s);
  const std::vector<Sample>& samples() const { return samples_; }
  /// A wheel's pulse rate (0 left, 1 right) over the samples of the last `window_s`
  /// [pulses/s]; 0 over less than 0.1 s.
  double rate(int side, double window_s) const;

  /// The update at `now_s`: the run's clock (RunWatch) and its failures of time and encoders
  /// ("the <what> took longer ... in <where>", ...), or empty; `dt_s` gets the time step [s].
  std::string tick(double now_s, bool moving, double max_duration_s, const std::string& what,
                   const std::string& where, double* dt_s);
  double elapsedS() const { return watch_.elapsedS(); }
  double lastS() const { return watch_.lastS(); }  ///< the last update's time [s]

  /// A motion decided at `now_s`: its clock starts at the next clock().start(), both wheels'
  /// duties at `duty`.
  void startMotion(double now_s, double duty);
  /// The samples start again from the counts now.
  void restartSamples();
  MotionClock& clock() { return clock_; }
  const MotionClock& clock() const { return clock_; }
  /// A wheel's duty magnitude [1].
  double duty(int side) const { return duty_[side]; }
  void setDuty(int side, double duty) { duty_[side] = duty; }
  /// One step of `dt_s` of a wheel's duty towards `target_pulses_per_s` from the measured rate.
  void follow(int side, double measured_pulses_per_s, double target_pulses_per_s, double dt_s);
  /// stallOf() for a driven wheel at its duty: the reason, or empty.
  std::string stall(int side, double now_s) const;
  /// The wheels stopped at `now_s`; settled(): SettleRule from then.
  void stop(double now_s) { stop_s_ = now_s; }
  bool settled(double now_s) const;

  const EncoderTracker& encoders() const { return encoders_; }

 private:
  EncoderDriveOptions options_;
  double max_settle_s_;
  EncoderTracker encoders_;
  RunWatch watch_;
  MotionClock clock_;
  std::vector<Sample> samples_;
  double duty_[2] = {0, 0};
  double stop_s_ = -1e9;
};

}  // namespace autocal
