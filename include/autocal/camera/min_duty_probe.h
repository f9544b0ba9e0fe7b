// The minimum duty that moves each wheel, found by the robot itself (paper 000 §3.2: "the minimum
// speed possible for the robot to move for a certain quantum of time (0.1 s) is fed to the
// wheel"). Real motors have a deadband, so it is measured, not assumed: the probe pulses one wheel
// at a time, raising the duty until the encoder (or the image) shows motion. The node sends each
// pulse, waits, and reports the ticks; the wheel stage and the kinematics reuse the result.
#pragma once

#include <algorithm>
#include <string>

#include "autocal/camera/wheel_turn.h"

namespace autocal {
namespace camera {

struct MinDutyProbeOptions {
  /// First duty tried [1].
  double start_duty = 0.02;
  /// Increase after a pulse without motion [1]; the result is at most this above the true minimum.
  double duty_step = 0.01;
  /// Highest duty tried; no motion up to it is a failure [1].
  double max_duty = 0.4;
  /// Encoder ticks a pulse must move the wheel by to count as motion (one tick may be a wheel
  /// that rested on a tick edge).
  int min_ticks = 2;
  /// Length of a pulse [s] (paper §3.2: a quantum of 0.1 s).
  double pulse_s = 0.1;
  /// Wait after a pulse before the ticks are read [s] (the wheel coasts to a stop).
  double settle_s = 0.3;
  /// Count image motion as motion too (when the encoder shows less than min_ticks).
  bool use_image_motion = true;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// Minimum moving duty magnitude per wheel and direction [1].
struct MinDutyResult {
  double left_forward = 0;
  double left_backward = 0;
  double right_forward = 0;
  double right_backward = 0;
  double forWheel(Wheel wheel, int sign) const;
  double forCommand(const WheelCommand& c) const { return forWheel(c.wheel, c.sign); }
};

/// Probes left forward, left backward, right forward, right backward, in this order.
class MinDutyProbe {
 public:
  /// Throws ConfigError when the options are invalid.
  explicit MinDutyProbe(const MinDutyProbeOptions& options);

  bool finished() const { return stage_ >= 4 || failed(); }
  bool failed() const { return !failure_.empty(); }
  /// Why it failed, e.g. "left wheel did not move backward up to duty 0.40: encoder or motor
  /// fault".
  const std::string& failure() const { return failure_; }

  /// The wheel and direction being probed, and the duty of the next pulse (while !finished()).
  WheelCommand command() const;
  double duty() const { return duty_; }
  /// command() at duty() as wheel duties.
  WheelDuties pulse() const { return toDuties(command(), duty_); }

  /// What the last pulse did: ticks the probed wheel moved from the start of the pulse to the end
  /// of the settle wait (signed: + = forward), and whether the image moved. Ignored once finished.
  void report(int ticks_moved, bool image_moved = false);

  /// Valid once finished() and !failed().
  const MinDutyResult& result() const { return result_; }
  /// Wheel directions probed so far, 0-4.
  int probed() const { return std::min(stage_, 4); }

 private:
  MinDutyProbeOptions options_;
  int stage_ = 0;  ///< 0 left+, 1 left-, 2 right+, 3 right-, 4 done
  double duty_;
  MinDutyResult result_;
  std::string failure_;
};

}  // namespace camera
}  // namespace autocal
