#include "autocal_ros/node_runtime.h"

#include <ros/callback_queue.h>
#include <ros/master.h>
#include <ros/network.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <filesystem>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/report/summary.h"
#include "autocal_ros/msg_conversion.h"

namespace autocal {
namespace ros_layer {

namespace {
std::atomic<bool> g_interrupted{false};
extern "C" void onSignal(int) { g_interrupted = true; }
// Whether this process's stage got past waiting for the stage before it (a status other than
// "<stage>/wait" was published).
std::atomic<bool> g_stage_started{false};
bool isWaitPhase(const std::string& phase) {
  return phase.size() >= 5 && phase.compare(phase.size() - 5, 5, "/wait") == 0;
}
}  // namespace

bool ok() { return ros::ok() && !g_interrupted; }
bool interrupted() { return g_interrupted; }

// A queue, not only the latest: statuses published in a burst (a replay's iteration, a FAILED
// right after a RUNNING) all reach the report. Latched: a late subscriber gets the last one.
StatusPublisher::StatusPublisher(ros::NodeHandle nh, const std::string& topic)
    : pub_(nh.advertise<CalibrationStatus>(topic, 50, true)), topic_(pub_.getTopic()) {}

void StatusPublisher::publish(uint8_t state, const std::string& phase, double progress,
                              const std::string& text, const std::string& failure_reason,
                              const Figures& figures, const std::string& file) {
  if (!pub_) return;
  if (!isWaitPhase(phase)) g_stage_started = true;
  CalibrationStatus s;
  s.header.stamp = ros::Time::now();
  s.phase = phase;
  s.state = state;
  s.progress = static_cast<float>(progress);
  s.text = text;
  s.failure_reason = failure_reason;
  s.file = file;
  for (const auto& f : figures) {
    s.figure_names.push_back(f.first);
    s.figure_values.push_back(f.second);
  }
  pub_.publish(s);
}

void StatusPublisher::running(const std::string& phase, double progress, const std::string& text,
                              const Figures& figures) {
  if (progress >= 0) progress = max_progress_ = std::max(progress, max_progress_);
  publish(CalibrationStatus::STATE_RUNNING, phase, progress, text, "", figures);
}

void StatusPublisher::done(const std::string& phase, const std::string& text,
                           const Figures& figures, const std::string& file) {
  publish(CalibrationStatus::STATE_DONE, phase, 1.0, text, "", figures, file);
}

void StatusPublisher::wrote(const std::string& phase, const std::string& file,
                            const Figures& figures) {
  done(phase, "wrote " + file, figures, file);
}

void StatusPublisher::failed(const std::string& phase, const std::string& reason,
                             const Figures& figures) {
  publish(CalibrationStatus::STATE_FAILED, phase, -1.0, "failed: " + reason, reason, figures);
}

WheelsCommander::WheelsCommander(ros::NodeHandle nh, const std::string& topic)
    : pub_(nh.advertise<dtmsg::WheelsCmdStamped>(topic, 10)) {}

void WheelsCommander::command(double left, double right) {
  if (!std::isfinite(left) || !std::isfinite(right)) {
    ROS_WARN_THROTTLE(1.0, "dropped a non-finite wheel duty (%f, %f)", left, right);
    return;
  }
  pub_.publish(
      toWheelsCmd({std::clamp(left, -1.0, 1.0), std::clamp(right, -1.0, 1.0)}, ros::Time::now()));
}

void WheelsCommander::stop(double repeat_s, double wait_for_subscriber_s) {
  if (!pub_) return;
  // Wall time on purpose: the stop must happen even when the sim clock has stopped.
  const ros::WallTime wait_end = ros::WallTime::now() + ros::WallDuration(wait_for_subscriber_s);
  while (pub_.getNumSubscribers() == 0 && ros::WallTime::now() < wait_end && ros::ok()) {
    pub_.publish(toWheelsCmd({0, 0}, ros::Time::now()));
    ros::WallDuration(0.05).sleep();
  }
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(repeat_s);
  do {
    pub_.publish(toWheelsCmd({0, 0}, ros::Time::now()));
    ros::WallDuration(0.05).sleep();
  } while (ros::WallTime::now() < end && ros::ok());
}

WheelsCommander connectStage(ros::NodeHandle nh, const std::function<bool()>& inputs_connected,
                             double wait_s) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(wait_s);
  while (ok() && ros::WallTime::now() < end && !inputs_connected()) {
    ros::WallDuration(0.01).sleep();
  }
  WheelsCommander wheels(nh, "wheels_driver_node/wheels_cmd");
  if (!wheels.waitForSubscriber(wait_s) && ok()) {
    // Checked before the first command: a stage that drove into nothing would wait out its
    // encoder timeout and blame the encoders.
    throw InputError("nobody subscribes to " + nh.resolveName("wheels_driver_node/wheels_cmd") +
                     " within " + formatNumber(wait_s, 3) +
                     " s (~connect_wait_s): is the wheels driver (or the simulator) running "
                     "under this vehicle name?");
  }
  return wheels;
}

bool WheelsCommander::waitForSubscriber(double timeout_s) {
  if (!pub_) return false;
  // Wall time: a simulator in lockstep holds its clock until the first command.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (pub_.getNumSubscribers() == 0 && ros::WallTime::now() < end && ok()) {
    ros::WallDuration(0.005).sleep();
  }
  return pub_.getNumSubscribers() > 0;
}

int runNode(int argc, char** argv, const NodeRunOptions& options,
            const std::function<void(ros::NodeHandle, ros::NodeHandle)>& body) {
  ros::init(argc, argv, options.name, ros::init_options::NoSigintHandler);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  // Held here, not only inside the node: when the last NodeHandle goes, ROS shuts down and with
  // it the logging and the publishers the failure path needs.
  ros::NodeHandle nh, pnh("~");
  StatusPublisher status(nh, options.status_topic);
  // Every node's ~failure_linger_s: a monitor started with the node (a test, a fleet dashboard)
  // may subscribe only after a failure found at start-up, and the latched FAILED goes with the
  // process.
  double linger_s = options.failure_linger_s;
  pnh.param("failure_linger_s", linger_s, linger_s);
  if (!std::isfinite(linger_s) || linger_s < 0) {
    ROS_WARN_STREAM(options.name << ": ~failure_linger_s " << linger_s
                                 << ": must be a finite number >= 0 [s]; using "
                                 << options.failure_linger_s);
    linger_s = options.failure_linger_s;
  }
  // Advertised only to stop: a simulator that waits for a controller starts its clock when a
  // wheels_cmd publisher appears, and the node advertises its own once its inputs are connected.
  // In the same process both share one connection, so the stop reaches the same subscribers.
  WheelsCommander wheels;
  auto stopWheels = [&] {
    if (!options.commands_wheels) return;
    if (!wheels.valid()) wheels = WheelsCommander(nh, options.wheels_topic);
    wheels.stop();
  };

  auto fail = [&](ExitCode code, const std::string& reason) {
    stopWheels();
    status.failed(options.phase, reason);
    ROS_FATAL_STREAM(options.name << ": " << exitCodeMeaning(code) << ": " << reason);
    // Give the latched FAILED a moment to reach subscribers that are connecting now.
    ros::WallDuration(linger_s).sleep();
    ros::shutdown();
    return toInt(code);
  };
  try {
    body(nh, pnh);
  } catch (const std::exception& e) {
    return fail(exitCodeFor(e), e.what());
  } catch (...) {
    return fail(ExitCode::kInternal, "unknown exception");
  }
  if (interrupted()) {
    // A stage still waiting for the one before it when the launch ends (that stage failed, or
    // the user stopped the run) was not interrupted: it never started. Quiet, no FAILED of its
    // own, so that the run's report names the real cause and shows this stage as not started.
    if (options.interrupt_is_failure && g_stage_started)
      return fail(ExitCode::kInterrupted, "interrupted by a signal");
    if (options.interrupt_is_failure)
      ROS_INFO_STREAM(options.name << ": stopped before its stage started");
    stopWheels();
  } else {
    ros::WallDuration(options.done_linger_s).sleep();
  }
  ros::shutdown();
  return toInt(ExitCode::kOk);
}

CalibrationStatus waitForStage(const ros::NodeHandle& nh, const std::string& stage,
                               double timeout_s) {
  ros::NodeHandle wait_nh(nh);
  ros::CallbackQueue queue;
  wait_nh.setCallbackQueue(&queue);
  CalibrationStatus done;
  std::string failure;
  bool have_done = false;
  const ros::Subscriber sub = wait_nh.subscribe<CalibrationStatus>(
      "calibration/status", 20, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->phase.rfind(stage + "/", 0) != 0) return;
        if (m->state == CalibrationStatus::STATE_FAILED) {
          failure = m->failure_reason.empty() ? m->text : m->failure_reason;
        } else if (m->state == CalibrationStatus::STATE_DONE) {
          done = *m;
          have_done = true;
        }
      });
  const ros::WallTime start = ros::WallTime::now();
  while (ok() && !have_done) {
    queue.callAvailable(ros::WallDuration(0.05));
    if (!failure.empty()) throw CalibrationError("the " + stage + " stage failed: " + failure);
    if (timeout_s > 0 && (ros::WallTime::now() - start).toSec() > timeout_s) {
      throw CalibrationError("no DONE from the " + stage + " stage within " +
                             formatNumber(timeout_s, 4) + " s");
    }
  }
  return have_done ? done : CalibrationStatus();
}

bool resumeStage(StatusPublisher& status, const std::string& calibration_root,
                 const std::string& veh, const std::string& stage) {
  const std::string summary =
      (std::filesystem::path(calibration_root) / "report" / veh / "summary.yaml").string();
  const report::PreviousStage p = report::previousStage(summary, stage);
  if (!p.done || p.file.empty() || !std::filesystem::exists(p.file)) {
    ROS_INFO("%s: ~resume: the %s stage runs (%s)", ros::this_node::getName().c_str(),
             stage.c_str(),
             !std::filesystem::exists(summary) ? "no earlier report"
             : !p.done                         ? "it did not succeed in the last run"
                                               : "its file is gone");
    return false;
  }
  ROS_INFO("%s: ~resume: the last run's %s stage succeeded (%s): kept, not run again",
           ros::this_node::getName().c_str(), stage.c_str(), summary.c_str());
  status.done(stage + "/resumed", "kept " + p.file, p.figures, p.file);
  // The DONE is latched, but only while this node lives: stay until the nodes started with it
  // (the next stage, run_report_node) have had time to connect and receive it.
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(3.0);
  while (ok() && ros::WallTime::now() < until) ros::WallDuration(0.05).sleep();
  return true;
}

int nodePid(const std::string& name) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = name;
  if (!ros::master::execute("lookupNode", args, result, payload, false)) return -1;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(payload), host, port)) return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue ping, answer;
  ping[0] = ros::this_node::getName();
  int pid = -1;
  // The answer is [code, status message, pid].
  if (client.execute("getPid", ping, answer) && !client.isFault() &&
      answer.getType() == XmlRpc::XmlRpcValue::TypeArray && answer.size() == 3 &&
      answer[2].getType() == XmlRpc::XmlRpcValue::TypeInt) {
    pid = static_cast<int>(answer[2]);
  }
  client.close();
  return pid;
}

}  // namespace ros_layer
}  // namespace autocal
