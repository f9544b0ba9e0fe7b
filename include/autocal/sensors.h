// What the robot's drivers report and take, as the core sees it (no ROS): wheel encoder readings
// and wheel duties. The ROS layer converts the Duckietown messages to and from these.
#pragma once

#include <cstdint>

namespace autocal {

/// One reading of a wheel encoder.
struct EncoderReading {
  double stamp_s = 0.0;          ///< [s]
  std::int32_t ticks = 0;        ///< cumulative count (may wrap around)
  int ticks_per_revolution = 0;  ///< resolution [ticks/rev]
};

/// One reading of a range sensor (REP 117: +inf nothing within range, -inf too close, NaN
/// invalid) with the sensor's limits.
struct RangeReading {
  double stamp_s = 0.0;      ///< [s]
  double range_m = 0.0;      ///< [m]
  double min_range_m = 0.0;  ///< [m]
  double max_range_m = 0.0;  ///< [m]
};

/// Duties of the two motors, −1..1 (Duckietown's wheels_cmd vel_left/vel_right).
struct WheelDuties {
  double left = 0.0;
  double right = 0.0;
};

}  // namespace autocal
