// What the robot's drivers report and take, as the core sees it (no ROS): wheel encoder readings
// and wheel duties. The ROS layer converts the Duckietown messages to and from these.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

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

/// Both wheels' encoders as one, the part every driving stage and replay shares: the latest
/// reading, the counts unwrapped (32-bit counts wrap around: the difference modulo 2^32 is the
/// motion), and when each wheel last changed. Readings older than the latest are ignored.
class EncoderTracker {
 public:
  /// What one reading added.
  struct Step {
    bool accepted = false;    ///< false: older than the latest reading, ignored
    bool first = false;       ///< the first reading (no motion to add)
    double left_ticks = 0.0;  ///< unwrapped increments since the previous reading
    double right_ticks = 0.0;
    double dt_s = 0.0;  ///< since the previous reading [s]
  };

  Step add(double stamp_s, std::int32_t left_ticks, std::int32_t right_ticks);

  bool valid() const { return valid_; }
  double stampS() const { return stamp_s_; }  ///< the latest reading's [s]
  double lastChangeS() const {
    return last_change_s_;
  }  ///< either count (the first reading counts)
  double lastChangeS(int side) const {
    return side == 0 ? last_change_left_s_ : last_change_right_s_;
  }
  std::int32_t rawLeft() const { return raw_left_; }  ///< as the latest reading gave them
  std::int32_t rawRight() const { return raw_right_; }
  double left() const { return left_; }  ///< unwrapped ticks since the first reading
  double right() const { return right_; }

  /// A reading at or after `since_s`, and no count changed for `still_s` before it.
  bool stillSince(double since_s, double still_s) const {
    return valid_ && stamp_s_ >= since_s && stamp_s_ - last_change_s_ >= still_s;
  }

  /// "encoder jump: left L, right R ticks in T s (an encoder reset or a glitch)" when `step` moved
  /// a wheel further than `max_rate_pulses_per_s` allows over max(its interval, `window_s`) plus 5
  /// ticks; empty otherwise.
  static std::string jump(const Step& step, double max_rate_pulses_per_s, double window_s);

 private:
  bool valid_ = false;
  double stamp_s_ = -1.0;
  double last_change_s_ = -1.0, last_change_left_s_ = -1.0, last_change_right_s_ = -1.0;
  std::int32_t raw_left_ = 0, raw_right_ = 0;
  double left_ = 0.0, right_ = 0.0;
};

/// Both wheels' counts at one instant, from the two encoders' separate readings. A robot's two
/// encoder drivers publish one after the other (or with their own stamps): paired as they arrive,
/// one wheel's count is always a reading behind the other's while the robot moves, which a path
/// integrated from them turns into a heading error of one reading's motion over the wheelbase
/// (about 5 degrees at 0.25 m/s and 30 Hz) and, since forward and backward drives err to the same
/// side, a lateral drift of centimetres per drive. Here a reading of one wheel is paired with the
/// other wheel's count interpolated to its stamp between the readings around it (never
/// extrapolated): readings of both wheels with the same stamp pair exactly.
class EncoderPairer {
 public:
  struct Pair {
    double stamp_s = 0.0;
    double left_ticks = 0.0;  ///< unwrapped counts (fractional where interpolated)
    double right_ticks = 0.0;
  };
  /// A reading of `side` (0 left, 1 right); returns the pairs it completes, in time order.
  /// Readings older than the wheel's latest are ignored; one with the same stamp replaces it.
  std::vector<Pair> add(int side, double stamp_s, std::int32_t ticks);

 private:
  struct Reading {
    double stamp_s;
    double ticks;
  };
  std::vector<Reading> readings_[2];  ///< per wheel, from the last one at or before paired_s_
  std::int32_t raw_[2] = {0, 0};
  double paired_s_ = -std::numeric_limits<double>::infinity();
};

/// Duties of the two motors, −1..1 (Duckietown's wheels_cmd vel_left/vel_right).
struct WheelDuties {
  double left = 0.0;
  double right = 0.0;
};

}  // namespace autocal
