#include "autocal/sensors.h"

#include <algorithm>
#include <cmath>

#include "autocal/io/format.h"

namespace autocal {

EncoderTracker::Step EncoderTracker::add(double stamp_s, std::int32_t left_ticks,
                                         std::int32_t right_ticks) {
  Step step;
  if (!valid_) {
    valid_ = true;
    raw_left_ = left_ticks, raw_right_ = right_ticks;
    stamp_s_ = last_change_s_ = last_change_left_s_ = last_change_right_s_ = stamp_s;
    step.accepted = step.first = true;
    return step;
  }
  if (stamp_s < stamp_s_) return step;
  const auto diff = [](std::int32_t now, std::int32_t before) {
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(now) -
                                     static_cast<std::uint32_t>(before));
  };
  step.accepted = true;
  step.left_ticks = diff(left_ticks, raw_left_);
  step.right_ticks = diff(right_ticks, raw_right_);
  step.dt_s = stamp_s - stamp_s_;
  raw_left_ = left_ticks, raw_right_ = right_ticks;
  left_ += step.left_ticks, right_ += step.right_ticks;
  if (step.left_ticks != 0) last_change_left_s_ = stamp_s;
  if (step.right_ticks != 0) last_change_right_s_ = stamp_s;
  if (step.left_ticks != 0 || step.right_ticks != 0) last_change_s_ = stamp_s;
  stamp_s_ = stamp_s;
  return step;
}

std::string EncoderTracker::jump(const Step& step, double max_rate_pulses_per_s, double window_s) {
  const double allowed = max_rate_pulses_per_s * std::max(step.dt_s, window_s) + 5;
  if (std::abs(step.left_ticks) <= allowed && std::abs(step.right_ticks) <= allowed) return {};
  return "encoder jump: left " + formatNumber(step.left_ticks, 8) + ", right " +
         formatNumber(step.right_ticks, 8) + " ticks in " + formatNumber(step.dt_s, 3) +
         " s (an encoder reset or a glitch)";
}

}  // namespace autocal
