#include "autocal/camera/wheel_turn.h"

#include "autocal/errors.h"

namespace autocal {
namespace camera {

const char* name(TurnDirection d) { return d == TurnDirection::kCcw ? "ccw" : "cw"; }

const char* name(Wheel w) { return w == Wheel::kLeft ? "left" : "right"; }

const char* name(PivotConvention p) {
  switch (p) {
    case PivotConvention::kPivotLeft:
      return "pivot_left";
    case PivotConvention::kPivotRight:
      return "pivot_right";
    case PivotConvention::kDriveForward:
      return "drive_forward";
    case PivotConvention::kDriveBackward:
      return "drive_backward";
  }
  return "?";
}

PivotConvention parsePivotConvention(const std::string& text) {
  for (PivotConvention p : {PivotConvention::kPivotLeft, PivotConvention::kPivotRight,
                            PivotConvention::kDriveForward, PivotConvention::kDriveBackward}) {
    if (text == name(p)) return p;
  }
  throw ConfigError("pivot '" + text +
                    "': expected pivot_left, pivot_right, drive_forward or drive_backward");
}

WheelCommand turnCommand(TurnDirection direction, PivotConvention pivot) {
  // Yaw grows when the right wheel moves forward relative to the left one, so CCW is "right wheel
  // forward" or "left wheel backward", and CW is "left wheel forward" or "right wheel backward".
  const bool ccw = direction == TurnDirection::kCcw;
  switch (pivot) {
    case PivotConvention::kPivotLeft:
      return {Wheel::kRight, ccw ? 1 : -1};
    case PivotConvention::kPivotRight:
      return {Wheel::kLeft, ccw ? -1 : 1};
    case PivotConvention::kDriveForward:
      return {ccw ? Wheel::kRight : Wheel::kLeft, 1};
    case PivotConvention::kDriveBackward:
      return {ccw ? Wheel::kLeft : Wheel::kRight, -1};
  }
  return {};
}

WheelDuties toDuties(const WheelCommand& command, double duty) {
  WheelDuties d;
  (command.wheel == Wheel::kLeft ? d.left : d.right) = command.sign * duty;
  return d;
}

}  // namespace camera
}  // namespace autocal
