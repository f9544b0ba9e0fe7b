// Waiting in rostests: callbacks are processed until a condition holds (a message arrived, sim
// time reached a value). The wall-clock budget is only a guard against a hung node, never a
// timing: nothing here sleeps for a duration.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>

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

}  // namespace test
}  // namespace autocal
