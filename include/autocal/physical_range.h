// What the dimensions of a small differential-drive robot (a Duckiebot and its kind) and of its
// calibration area can be, and a check that names the option and the likely unit slip when a
// value given in metres is off by 10, 100 or 1000. No ROS.
#pragma once

#include <string>

namespace autocal {

/// A length a robot of this size, or its calibration area, can have [m].
struct PhysicalRange {
  const char* what;  ///< e.g. "the wheelbase"
  double min_m;
  double max_m;
};

namespace ranges {
constexpr PhysicalRange kWheelbase{"the wheelbase", 0.05, 0.5};
constexpr PhysicalRange kWheelRadius{"a wheel radius", 0.01, 0.15};
constexpr PhysicalRange kUmbmarkSide{"the UMBmark square's side", 0.2, 10.0};
constexpr PhysicalRange kStraightRun{"a straight run", 0.1, 20.0};
constexpr PhysicalRange kBoardSquare{"a board square", 0.005, 0.2};
constexpr PhysicalRange kTagSize{"a tag's side", 0.02, 0.5};
constexpr PhysicalRange kCameraHeight{"the camera's height above the floor", 0.03, 0.5};
}  // namespace ranges

/// Empty when `value_m` lies in `range`, or is not a positive finite number (the options' own
/// checks name those). Otherwise "<option> <value>: <what> of a robot of this size is <min>–<max>
/// m", and, when the value divided by 1000, 100 or 10 lies in the range, "; <value> looks like
/// millimetres (<value/1000> m)" (or centimetres, decimetres).
std::string outOfRange(const std::string& option, double value_m, const PhysicalRange& range);

}  // namespace autocal
