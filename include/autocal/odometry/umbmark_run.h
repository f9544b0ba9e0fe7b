// UMBmark (Borenstein & Feng 1996; paper 002 §1.2, §3.2) driven by the robot itself, ROS-free:
// the robot drives an L×L square `runs_per_direction` times clockwise, then as many times
// counter-clockwise, each on its own encoder dead reckoning (closed loop on its odometry: straight
// legs of L by odometry distance with heading and cross-track hold, 90° turns in place by odometry
// heading). Each run starts where the previous one stopped, with odometry reset to (0, 0, 0): the
// square of umbmark.h's conventions in that run's frame (first leg along +x; clockwise turns
// right). After each run the robot stops, waits until it stands still, and waits for that run's
// return error ε = actual − computed end position [m] in the run's start frame (umbmark.h): typed
// by a person on a robot, or in the simulator by a ground-truth helper. Then computeUmbmark.
// The caller feeds time and encoder readings and commands the duties update() returns; a run's
// clock starts at the first update() that returns its duties. Failures throw CalibrationError
// (and the run stays failed with zero duties).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autocal/motion.h"
#include "autocal/odometry/dead_reckoning.h"
#include "autocal/odometry/umbmark.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"

namespace autocal {
namespace odometry {

/// The drive's options (EncoderDriveOptions) and the squares'.
struct UmbmarkRunOptions : EncoderDriveOptions {
  /// The odometry the squares are driven on (nominal, or an earlier calibration's).
  DiffDriveParams nominal;
  /// The side L of the square [m] (1 m suits a Duckiebot; Borenstein used 4 m).
  double side_m = 1.0;
  /// Runs in each direction (Borenstein: 5).
  int runs_per_direction = 5;
  UmbmarkExpressions expressions = UmbmarkExpressions::kCorrected;
  /// Each wheel's pulse rate on the legs and in the turns [pulses/s].
  double drive_rate_pulses_per_s = 120.0;
  double turn_rate_pulses_per_s = 40.0;
  /// A leg's rate rises from the turn rate to the drive rate over this time [s].
  double ramp_s = 1.0;
  /// Heading hold on the legs, on the heading error expressed in wheel pulses (e·b/c̄): the
  /// right duty gets +gain·e (+ integral), the left −: [duty/pulse], [duty/(pulse·s)].
  double heading_gain_duty_per_pulse = 0.01;
  double heading_integral_duty_per_pulse_s = 0.03;
  /// Cross-track hold: the wanted heading bends towards the leg's line by atan(gain·offset).
  double cross_track_gain_per_m = 3.0;
  /// A motion's duties stop this long before its odometry target (the wheels coast for about
  /// their lag after a stop; odometry counts the coasting, so this only keeps the square tidy) [s].
  double stop_lead_s = 0.06;
  /// A given return error larger than this fraction of the side is refused (centimetres given as
  /// metres, a wrong measurement). An uncalibrated Duckiebot whose wheelbase is 9 % off its
  /// nominal one comes back about one side away from where it started.
  double max_return_error_fraction = 2.0;
  /// Bound of the whole run [s] (0: none) and of waiting for a return error [s] (0: none).
  double max_duration_s = 1800.0;
  double error_timeout_s = 0.0;
  /// Errors after all squares instead of after each: the robot pauses run_pause_s after each
  /// square (a person marks where it stopped) and starts the next from there; at the end it waits
  /// for every error at once (setReturnErrors: from a file).
  bool errors_after_all = false;
  double run_pause_s = 10.0;
  /// Errors after all squares from this YAML file (loadUmbmarkErrors' format): once every square
  /// is driven, update() reads it every second until it holds every square's error (a person
  /// writes it once all are measured; a half-written file is read again). Empty: the caller gives
  /// them (setReturnErrors).
  std::string errors_file;
  /// Where the return errors come from, recorded in the file ("~return_error", a file's path).
  std::string errors_source = "~return_error";
  /// Throws ConfigError naming the first bad key.
  void validate() const;
  /// One line for a log: the squares the run will drive and where their errors come from.
  std::string summary() const;
  /// The options computeUmbmark gets (side, nominal wheelbase, expressions).
  UmbmarkOptions umbmark() const;
};

enum class UmbmarkPhase { kWait, kClockwise, kCounterClockwise, kDone, kFailed };
/// "wait", "umbmark_cw", "umbmark_ccw", "done", "failed".
const char* name(UmbmarkPhase phase);

class UmbmarkRun : public Stage {
 public:
  /// Throws ConfigError on bad options.
  explicit UmbmarkRun(const UmbmarkRunOptions& options);

  /// Cumulative ticks (wrapping 32-bit counts are unwrapped). Throws CalibrationError on a reset or
  /// jump. Stamps going back are dropped.
  /// The resolution is the nominal's (ticks_per_revolution and now_s are not used).
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution = 0,
                   double now_s = 0) override;
  /// Whether the run just driven waits for its return error.
  bool needsReturnError() const { return awaiting_error_; }
  /// That run's return error ε = actual − computed [m], in its start frame (x along the first
  /// leg). Throws InputError when none is awaited or it is not finite, CalibrationError when it is
  /// larger than max_return_error_fraction of the side.
  void setReturnError(const ReturnError& error);
  /// Errors-after-all mode: whether every square is driven and the errors are awaited.
  bool needsAllReturnErrors() const { return awaiting_all_; }
  /// Every square's return error, runs_per_direction of each (as setReturnError). Throws
  /// InputError when none are awaited or the counts differ, CalibrationError as setReturnError.
  void setReturnErrors(const std::vector<ReturnError>& cw, const std::vector<ReturnError>& ccw);
  /// The computed end of each square driven so far, in its start frame [m].
  const std::vector<Pose2D>& computedEnds() const { return computed_ends_; }
  /// Advances the run; returns the duties to command now (zero when done, failed or waiting).
  WheelDuties update(double now_s) override;

  UmbmarkPhase phase() const { return phase_; }
  bool done() const override { return phase_ == UmbmarkPhase::kDone; }
  bool failed() const { return phase_ == UmbmarkPhase::kFailed; }
  const std::string& failure() const { return failure_; }
  /// Valid once done().
  const UmbmarkResult& result() const { return result_; }
  /// The return errors given so far.
  const std::vector<ReturnError>& clockwiseErrors() const { return cw_; }
  const std::vector<ReturnError>& counterClockwiseErrors() const { return ccw_; }
  /// The run under way or waiting (1-based within its direction), its leg (1-4) and the time its
  /// duties first went out [s] (the robot stood still until then: a helper measures from there).
  int runInDirection() const;
  int leg() const { return leg_ + 1; }
  double runStartS() const { return run_start_s_; }
  /// The odometry's pose in the current run's frame (its end pose while waiting for the error).
  const Pose2D& computedPose() const { return odometry_.pose(); }
  /// 0..1, the share of the runs done.
  double progress() const;
  double elapsedS() const { return drive_.elapsedS(); }
  /// One line: direction, run, leg, last figures.
  std::string describe() const;
  /// Step: the direction; key: the square, its leg and the waits for return errors.
  StageStatus status() const override;
  /// Writes <calibration_root>/odometry/<veh>.yaml (its quality gate first); valid once done().
  StageResult finish(const StageOutput& output) override;

 private:
  enum class Motion { kNone, kDrive, kTurn, kSettle, kPause };

  /// Errors-file mode: reads the file when a second has passed; takes it when it is whole.
  void readErrorsFile(double now_s);
  [[noreturn]] void fail(const std::string& why);
  void startRun(double now_s);
  void startLeg(double now_s);
  void startTurn(double now_s);
  void stop(double now_s);
  void onSettled(double now_s);
  void finish();
  /// Refuses an error that is not finite or larger than the limit.
  void checkError(const ReturnError& error, const std::string& which);
  double wheelRate(int side) const;
  /// +1 counter-clockwise, −1 clockwise.
  double turnSign() const { return phase_ == UmbmarkPhase::kClockwise ? -1.0 : 1.0; }

  UmbmarkRunOptions options_;
  UmbmarkPhase phase_ = UmbmarkPhase::kWait;
  Motion motion_ = Motion::kNone;
  std::string failure_;
  UmbmarkResult result_;
  std::vector<ReturnError> cw_, ccw_;

  /// The run's clock, the encoders, the last second's samples (wheel rates), the current
  /// motion's clock, the wheels' duties.
  EncoderDrive drive_;

  DeadReckoning odometry_;
  int runs_done_ = 0;         // runs whose error was given
  int leg_ = 0;               // 0..3: leg k, then turn k
  bool was_turning_ = false;  // in (or settling after) turn leg_
  bool awaiting_error_ = false, awaiting_all_ = false;
  double pause_until_s_ = 0;
  std::vector<Pose2D> computed_ends_;
  double awaiting_since_s_ = 0;
  /// Errors-file mode: when the file was last read, and why it was not taken then.
  double errors_file_read_s_ = -1e9;
  std::string errors_file_wait_;
  double run_start_s_ = 0;
  WheelDuties duties_;
  double drive_duty_ = 0, turn_duty_[2] = {0, 0};
  double heading_integral_ = 0;
};

}  // namespace odometry
}  // namespace autocal
