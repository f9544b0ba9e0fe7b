// Waiting in rostests: callbacks are processed until a condition holds (a message arrived, sim
// time reached a value). The wall-clock budget is only a guard against a hung node, never a
// timing: nothing here sleeps for a duration.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace autocal {
namespace test {

/// Processes callbacks until `done()`; false when `wall_budget_s` runs out first.
template <typename F>
bool spinUntil(F done, double wall_budget_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(wall_budget_s);
  while (ros::ok() && !done() && ros::WallTime::now() < deadline) {
    // Blocks until a message arrives (at most 10 ms), then handles all that are queued.
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.01));
  }
  return done();
}

/// Processes callbacks until sim time reaches `t_s`.
inline bool spinUntilSimTime(double t_s, double wall_budget_s) {
  return spinUntil([&] { return ros::Time::isValid() && ros::Time::now().toSec() >= t_s; },
                   wall_budget_s);
}

/// Removes an earlier test run's files under `path` while the launch's nodes start: they create
/// their output folders at once (the stages' preflight), which can make one pass of remove_all
/// find a folder not empty. Retries until the tree is gone; false if it never is.
inline bool removeTree(const std::string& path) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
    if (!ec && !std::filesystem::exists(path, ec)) return true;
  }
  return false;
}

}  // namespace test
}  // namespace autocal
