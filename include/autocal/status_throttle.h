// When a stage publishes its RUNNING status: at once when what a watcher acts on changed (the
// phase, a round, a wait for input: the stage's key), otherwise at most at a rate. No ROS.
#pragma once

#include <string>
#include <utility>

namespace autocal {

class StatusThrottle {
 public:
  explicit StatusThrottle(double rate_hz = 1.0) : period_s_(1.0 / rate_hz) {}

  /// True when a status is due at `now_s` for `key` (always when `force`); it then counts as
  /// published, and keyChanged() says whether the key differs from the one published before.
  bool due(const std::string& key, double now_s, bool force = false) {
    if (!force && key == key_ && now_s - last_s_ < period_s_) return false;
    changed_ = key != key_;
    key_ = key;
    last_s_ = now_s;
    return true;
  }
  bool keyChanged() const { return changed_; }
  const std::string& key() const { return key_; }

 private:
  double period_s_;
  std::string key_;
  double last_s_ = 0.0;
  bool changed_ = false;
};

}  // namespace autocal
