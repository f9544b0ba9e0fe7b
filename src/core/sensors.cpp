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

std::vector<EncoderPairer::Pair> EncoderPairer::add(int side, double stamp_s, std::int32_t ticks) {
  std::vector<Reading>& mine = readings_[side];
  if (!mine.empty() && stamp_s < mine.back().stamp_s) return {};
  const double unwrapped =
      mine.empty()
          ? ticks
          : mine.back().ticks + static_cast<std::int32_t>(static_cast<std::uint32_t>(ticks) -
                                                          static_cast<std::uint32_t>(raw_[side]));
  raw_[side] = ticks;
  if (!mine.empty() && stamp_s == mine.back().stamp_s) {
    mine.back().ticks = unwrapped;
  } else {
    mine.push_back({stamp_s, unwrapped});
  }
  std::vector<Pair> out;
  while (!readings_[0].empty() && !readings_[1].empty()) {
    // The next instant to pair: the earliest reading of either wheel after the last pair.
    double next_s = std::numeric_limits<double>::infinity();
    for (const std::vector<Reading>& r : readings_)
      for (const Reading& x : r)
        if (x.stamp_s > paired_s_) {
          next_s = std::min(next_s, x.stamp_s);
          break;
        }
    if (!std::isfinite(next_s)) break;
    // Both wheels need a reading at or after it to interpolate to it.
    if (readings_[0].back().stamp_s < next_s || readings_[1].back().stamp_s < next_s) break;
    double at[2] = {0.0, 0.0};
    bool before_first = false;
    for (int s = 0; s < 2; ++s) {
      const std::vector<Reading>& r = readings_[s];
      if (r.front().stamp_s > next_s) {
        before_first = true;  // before this wheel's first reading: never pairable
        break;
      }
      size_t i = 0;  // the last reading at or before it
      while (i + 1 < r.size() && r[i + 1].stamp_s <= next_s) ++i;
      if (r[i].stamp_s == next_s || i + 1 == r.size()) {
        at[s] = r[i].ticks;
      } else {
        const double f = (next_s - r[i].stamp_s) / (r[i + 1].stamp_s - r[i].stamp_s);
        at[s] = r[i].ticks + f * (r[i + 1].ticks - r[i].ticks);
      }
    }
    paired_s_ = next_s;
    if (!before_first) out.push_back({next_s, at[0], at[1]});
    // Keep from each wheel's last reading at or before the pair on.
    for (std::vector<Reading>& r : readings_) {
      size_t keep = 0;
      while (keep + 1 < r.size() && r[keep + 1].stamp_s <= paired_s_) ++keep;
      r.erase(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(keep));
    }
  }
  return out;
}

std::string EncoderTracker::jump(const Step& step, double max_rate_pulses_per_s, double window_s) {
  const double allowed = max_rate_pulses_per_s * std::max(step.dt_s, window_s) + 5;
  if (std::abs(step.left_ticks) <= allowed && std::abs(step.right_ticks) <= allowed) return {};
  return "encoder jump: left " + formatNumber(step.left_ticks, 8) + ", right " +
         formatNumber(step.right_ticks, 8) + " ticks in " + formatNumber(step.dt_s, 3) +
         " s (an encoder reset or a glitch)";
}

}  // namespace autocal
