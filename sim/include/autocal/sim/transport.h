// How a message travels from a robot's sensor driver (or its controller) to the node that reads
// it: a latency with jitter, a chance to be lost, and the order kept. No ROS: the simulator node
// queues its messages here and publishes (or applies, for wheel commands) each at its release
// time; the message keeps its capture stamp, as a Duckiebot's drivers stamp theirs.
#pragma once

#include <cstdint>
#include <deque>
#include <random>
#include <utility>
#include <vector>

namespace autocal {
namespace sim {

/// One link's delays (robot YAML `transport:`).
struct LinkConfig {
  double latency_s = 0.0;         ///< mean delay from capture to arrival [s]
  double jitter_s = 0.0;          ///< standard deviation of the delay [s] (never below 0 delay)
  double drop_probability = 0.0;  ///< chance a message is lost, 0..1
  bool active() const { return latency_s > 0 || jitter_s > 0 || drop_probability > 0; }
};

/// The release times of one link's messages, in the order they were sent.
class DelayLine {
 public:
  DelayLine(const LinkConfig& config, uint64_t seed) : config_(config), rng_(seed) {}
  /// The time a message sent at `t_s` arrives: t_s + latency + jitter, and never before the
  /// message sent before it (a link keeps order). Negative when the message is lost.
  double releaseTime(double t_s);
  const LinkConfig& config() const { return config_; }

 private:
  LinkConfig config_;
  std::mt19937_64 rng_;
  double last_release_s_ = -1e300;
};

/// Messages held until their release time.
template <class T>
class DelayQueue {
 public:
  DelayQueue(const LinkConfig& config, uint64_t seed) : line_(config, seed) {}
  /// Queues `message` sent at `t_s` (a lost one is dropped here); false when lost.
  bool push(double t_s, T message) {
    const double release = line_.releaseTime(t_s);
    if (release < 0) return false;
    held_.emplace_back(release, std::move(message));
    return true;
  }
  /// The messages released by `now_s`, in order.
  std::vector<T> due(double now_s) {
    std::vector<T> out;
    while (!held_.empty() && held_.front().first <= now_s) {
      out.push_back(std::move(held_.front().second));
      held_.pop_front();
    }
    return out;
  }
  size_t held() const { return held_.size(); }

 private:
  DelayLine line_;
  std::deque<std::pair<double, T>> held_;
};

}  // namespace sim
}  // namespace autocal
