// The parts every robot-driving stage is built from, beside the encoders (sensors.h
// EncoderTracker): when a stop has settled, when the current motion started, how a wheel's duty
// follows a pulse rate, and when a driven wheel has stalled. No ROS.
#pragma once

#include <string>

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

  /// Why the run must fail at `now_s`, or empty: it ran longer than `max_duration_s` (> 0; "the
  /// <what> took longer than max_duration_s (T s) in <where>"), no encoder reading came within
  /// `encoder_timeout_s` of its start ("no encoder readings"), or, while `moving`, none came for
  /// `encoder_timeout_s` ("the encoders went silent for T s").
  std::string failure(double now_s, const EncoderTracker& encoders, bool moving,
                      double max_duration_s, double encoder_timeout_s, const std::string& what,
                      const std::string& where) const;

 private:
  bool started_ = false;
  double start_s_ = 0.0, last_s_ = 0.0;
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

}  // namespace autocal
