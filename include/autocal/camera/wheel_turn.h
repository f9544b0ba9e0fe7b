// Turning by driving ONE wheel (paper 000 §3.2): the other wheel stands still, so the robot pivots
// on that wheel's contact point and wheels that are not calibrated yet do not matter. Which wheel
// drives and with which sign follows from the turn direction and a pivot convention.
#pragma once

#include <string>

#include "autocal/sensors.h"

namespace autocal {
namespace camera {

enum class Wheel { kLeft, kRight };

/// Direction of a turn seen from above: counter-clockwise = +yaw (to the left).
enum class TurnDirection { kCcw = 1, kCw = -1 };

inline int sign(TurnDirection d) { return static_cast<int>(d); }
inline TurnDirection opposite(TurnDirection d) {
  return d == TurnDirection::kCcw ? TurnDirection::kCw : TurnDirection::kCcw;
}
const char* name(TurnDirection d);  ///< "ccw" or "cw"
const char* name(Wheel w);          ///< "left" or "right"

/// Which wheel stands still while the robot turns.
enum class PivotConvention {
  /// Always pivot on the left wheel (the right wheel drives: forward = CCW, backward = CW). The
  /// pivot point stays put over any number of back-and-forth passes.
  kPivotLeft,
  /// Always pivot on the right wheel (the left wheel drives: forward = CW, backward = CCW).
  kPivotRight,
  /// The driving wheel always goes forward (CCW: right wheel, CW: left wheel). The pivot point
  /// changes with the direction, so the robot creeps forward over passes.
  kDriveForward,
  /// The driving wheel always goes backward (CCW: left wheel, CW: right wheel); creeps backward.
  kDriveBackward,
};
/// Parses "pivot_left", "pivot_right", "drive_forward", "drive_backward"; ConfigError otherwise.
PivotConvention parsePivotConvention(const std::string& text);
const char* name(PivotConvention p);

/// One wheel driven with a sign; the other stopped.
struct WheelCommand {
  Wheel wheel = Wheel::kLeft;
  int sign = 1;  ///< +1 forward, -1 backward
};

/// Duties for both wheels (-1..1), as wheels_cmd takes them: the one type of autocal/sensors.h.
using autocal::WheelDuties;

/// The wheel and sign that turn the robot in `direction` under `pivot` (right wheel forward or left
/// wheel backward turn it counter-clockwise; the other two clockwise).
WheelCommand turnCommand(TurnDirection direction, PivotConvention pivot);

/// `command` at duty magnitude `duty` (>= 0) on its wheel, 0 on the other.
WheelDuties toDuties(const WheelCommand& command, double duty);

}  // namespace camera
}  // namespace autocal
