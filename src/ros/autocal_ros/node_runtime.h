// What every autocal node shares at run time: the latched status of doc/calibration_run.md
// "The status protocol",
// the wheels' stop, and the one failure path (stop the wheels until the stop is seen, publish
// FAILED with the reason, ROS_FATAL, exit with the code of the one table, doc/calibration_run.md
// "Exit codes").
// SIGINT and SIGTERM stop the wheels too.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "autocal/exit_codes.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace ros_layer {

/// Publishes autocal/CalibrationStatus, latched, on one topic.
class StatusPublisher {
 public:
  StatusPublisher() = default;
  StatusPublisher(ros::NodeHandle nh, const std::string& topic);

  using Figures = autocal::Figures;
  /// `progress` 0..1, negative when unknown. A stage's progress never goes back: a lower value
  /// than one published before (a stage re-aligning, a phase whose own measure starts lower) is
  /// published as the higher one.
  void running(const std::string& phase, double progress, const std::string& text,
               const Figures& figures = {});
  /// DONE; `file`: the file the stage wrote or kept, for the next stage and the report.
  void done(const std::string& phase, const std::string& text, const Figures& figures = {},
            const std::string& file = "");
  /// DONE with the file the stage wrote: text "wrote <file>", and the file in its own field.
  void wrote(const std::string& phase, const std::string& file, const Figures& figures = {});
  void failed(const std::string& phase, const std::string& reason, const Figures& figures = {});
  const std::string& topic() const { return topic_; }
  /// Subscribers connected to the status topic now.
  uint32_t subscribers() const { return pub_.getNumSubscribers(); }

 private:
  void publish(uint8_t state, const std::string& phase, double progress, const std::string& text,
               const std::string& failure_reason, const Figures& figures,
               const std::string& file = "");
  ros::Publisher pub_;
  std::string topic_;
  double max_progress_ = 0.0;
};

/// Publishes wheels_cmd; stop() sends zero duties until a subscriber has seen them.
class WheelsCommander {
 public:
  WheelsCommander() = default;
  WheelsCommander(ros::NodeHandle nh, const std::string& topic);
  /// Drops (with a throttled warning) non-finite duties and clamps to ±1.
  void command(double left_duty, double right_duty);
  /// Zero duty, repeated: every 50 ms for `repeat_s` [wall s] once a subscriber is connected
  /// (waiting up to `wait_for_subscriber_s` for one), so that a dropped message cannot leave the
  /// wheels turning.
  void stop(double repeat_s = 0.3, double wait_for_subscriber_s = 1.0);
  /// Waits up to `timeout_s` [wall s] until a subscriber (the wheels' driver, the simulator) is
  /// connected; true when one is. A node that starts driving calls it once after advertising: a
  /// command published before the subscriber connected is lost, and a simulator in lockstep
  /// (sim_node ~lockstep_s) holds its clock until a command arrives, so a control loop sleeping
  /// on that clock would wait for a command it already sent (until the simulator gives up after
  /// ~lockstep_wait_s of wall time and runs free, at real_time_factor 0 far ahead of the node).
  bool waitForSubscriber(double timeout_s);
  bool valid() const { return static_cast<bool>(pub_); }

 private:
  ros::Publisher pub_;
};

/// True until ROS shuts down or SIGINT/SIGTERM arrived (runNode installs the handlers).
bool ok();

/// Connects a driving stage in the order a simulator holding its clock needs: waits up to
/// `wait_s` [wall s] until `inputs_connected()` (its inputs have publishers; a simulator started
/// with wait_for_controller holds its clock until a wheels_cmd publisher appears, and a held clock
/// does not move), then advertises wheels_driver_node/wheels_cmd and waits up to `wait_s` for a
/// subscriber, so that the first command is not lost (WheelsCommander::waitForSubscriber). Inputs
/// that never connect are left to the stage's own timeouts. Throws InputError when nobody
/// subscribes to wheels_cmd within `wait_s`: the robot cannot be driven.
WheelsCommander connectStage(ros::NodeHandle nh, const std::function<bool()>& inputs_connected,
                             double wait_s);

/// What a stage node's callbacks saw in one batch (they set these; runStageLoop clears them).
struct Arrivals {
  bool frames = false;
  bool encoders = false;
};

/// The control loop of a stage node (camera, wheels): at `rate_hz` of the node's clock it handles
/// the callbacks, rethrows what a callback kept in `error`, tells the stage what arrived in the
/// batch (it arrived now: processing a frame in it may have taken a while of sim time, and at
/// real_time_factor 0 the simulator runs on meanwhile), commands the duties stage.update(now)
/// returns and calls `publish_status`, until `done()`. Returns false when interrupted (runNode
/// then stops the wheels); true when done, after stopping the wheels.
template <class Stage, class Done, class Status>
bool runStageLoop(Stage& stage, Done done, double rate_hz, const std::exception_ptr& error,
                  Arrivals& arrivals, WheelsCommander& wheels, Status publish_status) {
  ros::Rate rate(rate_hz);
  while (ok() && !done()) {
    arrivals = Arrivals();
    ros::spinOnce();
    if (error) std::rethrow_exception(error);
    const double now = ros::Time::now().toSec();
    if (arrivals.frames) stage.noteFrameArrived(now);
    if (arrivals.encoders) stage.noteEncodersArrived(now);
    const WheelDuties duties = stage.update(now);
    wheels.command(duties.left, duties.right);
    publish_status();
    rate.sleep();
  }
  if (!ok()) return false;
  wheels.stop();
  return true;
}
/// True after SIGINT or SIGTERM.
bool interrupted();

/// Waits on `nh`'s calibration/status for the stage `stage` (e.g. "wheels") to publish DONE and
/// returns that message; throws CalibrationError when the stage (or run_report_node in its name,
/// "<stage>/died") publishes FAILED, or when `timeout_s` wall seconds pass (0: no limit). Returns
/// an empty message when interrupted. Its own callback queue: the caller's subscriptions wait.
CalibrationStatus waitForStage(const ros::NodeHandle& nh, const std::string& stage,
                               double timeout_s);

/// Resuming a run after a failure (a stage's ~resume): when the run's last report,
/// <calibration_root>/report/<veh>/summary.yaml, says `stage` was DONE and the file it named
/// still exists, publishes that DONE again ("kept <file>", the same figures) and returns true:
/// the stage need not run again. False otherwise (no report, the stage failed, the file is gone).
bool resumeStage(StatusPublisher& status, const std::string& calibration_root,
                 const std::string& veh, const std::string& stage);

/// The process id of the ROS node `name` (e.g. "/autobot/wheel_calibration_node"), asked over its
/// XML-RPC port as `rosnode ping` does; -1 when the master does not know it or it does not answer
/// (a killed node stays registered, but its port is closed).
int nodePid(const std::string& name);

struct NodeRunOptions {
  std::string name;  ///< ros::init name and log prefix, e.g. "sim_node"
  std::string status_topic = "calibration/status";
  std::string phase;            ///< the phase a FAILED status names, e.g. "camera"
  bool commands_wheels = true;  ///< stop the wheels on failure and interrupt
  std::string wheels_topic = "wheels_driver_node/wheels_cmd";
  /// How long [wall s] a failed node keeps its latched FAILED up before it exits, for subscribers
  /// that are still connecting (a node started with it in the same launch); the node's private
  /// parameter ~failure_linger_s overrides it.
  double failure_linger_s = 1.0;
  /// How long [wall s] a node that ended normally stays up before it exits: a status published just
  /// before (the stage's DONE) is still in the publisher's queue, and shutting down at once
  /// closes the connections under it, so that a watcher sees the node gone with no DONE.
  double done_linger_s = 0.5;
  /// Exit 130 with FAILED "interrupted" once the stage has started (published a phase other than
  /// "<stage>/wait"); before that, and when false, an interrupt ends the node quietly with 0.
  bool interrupt_is_failure = true;
};

/// The main of every node: ros::init, then `body(nh, pnh)` (which constructs the node and runs
/// it), catching every exception once and taking the failure path. Returns the exit code.
int runNode(int argc, char** argv, const NodeRunOptions& options,
            const std::function<void(ros::NodeHandle, ros::NodeHandle)>& body);

}  // namespace ros_layer
}  // namespace autocal
