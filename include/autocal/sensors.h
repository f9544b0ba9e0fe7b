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

/// The latest reading of both wheels' encoders and when either last changed: what "the wheels are
/// still" is decided on. Readings older than the latest are ignored.
struct EncoderTrack {
  bool valid = false;
  double stamp_s = -1.0;        ///< the latest reading's [s]
  double last_change_s = -1.0;  ///< when a count last changed (the first reading counts) [s]
  int left = 0, right = 0;      ///< cumulative ticks

  /// False (and ignored) when older than the latest reading.
  bool add(double reading_stamp_s, int left_ticks, int right_ticks) {
    if (valid && reading_stamp_s < stamp_s) return false;
    if (!valid || left_ticks != left || right_ticks != right) last_change_s = reading_stamp_s;
    valid = true;
    stamp_s = reading_stamp_s;
    left = left_ticks;
    right = right_ticks;
    return true;
  }
  /// A reading at or after `since_s`, and no count changed for `still_s` before it.
  bool stillSince(double since_s, double still_s) const {
    return valid && stamp_s >= since_s && stamp_s - last_change_s >= still_s;
  }
};

/// Duties of the two motors, −1..1 (Duckietown's wheels_cmd vel_left/vel_right).
struct WheelDuties {
  double left = 0.0;
  double right = 0.0;
};

}  // namespace autocal
