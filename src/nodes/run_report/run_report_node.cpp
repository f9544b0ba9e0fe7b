#include "run_report_node.h"

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>

#include <filesystem>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/pose2d.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace report {

namespace fs = std::filesystem;

void RunReportNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkCalibrationRoot(calibration_root);
  for (const std::string& s : stages)
    ros_layer::checkParam(s == "camera" || s == "wheels" || s == "odometry", "stages",
                          "each must be camera, wheels or odometry (got '" + s + "')");
  ros_layer::checkParam(std::isfinite(stage_start_timeout_s) && stage_start_timeout_s >= 0,
                        "stage_start_timeout_s", "must be >= 0 [s]");
  ros_layer::checkParam(std::isfinite(ping_period_s) && ping_period_s > 0, "ping_period_s",
                        "must be > 0 [s]");
  ros_layer::checkParam(std::isfinite(silent_warn_s) && silent_warn_s >= 0, "silent_warn_s",
                        "must be >= 0 [s] (0: never warn)");
  ros_layer::checkParam(std::isfinite(path_rate_hz) && path_rate_hz > 0, "path_rate_hz",
                        "must be > 0 [Hz]");
  ros_layer::checkParam(!odom_frame.empty(), "odom_frame", "must not be empty");
}

RunReportNode::RunReportNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
  const ros_layer::ParamReader p(pnh_, "run_report_node");
  options_.veh = ros_layer::defaultVeh(nh_);
  p.get("veh", options_.veh);
  p.get("calibration_root", options_.calibration_root);
  std::string stages = "camera,wheels";
  p.get("stages", stages);
  options_.stages = splitCommaList(stages);
  p.get("report_dir", options_.report_dir);
  if (options_.report_dir.empty())
    options_.report_dir = (fs::path(options_.calibration_root) / "report" / options_.veh).string();
  p.get("stage_start_timeout_s", options_.stage_start_timeout_s);
  p.get("ping_period_s", options_.ping_period_s);
  p.get("resume", options_.resume);
  p.get("silent_warn_s", options_.silent_warn_s);
  p.get("path_rate_hz", options_.path_rate_hz);
  p.get("true_pose_topic", options_.true_pose_topic);
  options_.odom_frame = options_.veh + "/odom";
  p.get("odom_frame", options_.odom_frame);
  options_.validate();
  checkWritableFolder(options_.report_dir);  // before the run: the report is written at its end
  recorder_ = std::make_unique<RunRecorder>(options_.veh, options_.stages);  // throws ConfigError

  status_ = ros_layer::StatusPublisher(nh_, "calibration/status");
  status_sub_ = nh_.subscribe("calibration/status", 50, &RunReportNode::onStatus, this);
  // A simulator that fails (a bad robot or world config: the FATAL names file, line and key) ends
  // the run with its reason, not "interrupted".
  sim_status_sub_ = nh_.subscribe<autocal::CalibrationStatus>(
      "sim/status", 5, [this](const autocal::CalibrationStatus::ConstPtr& m) {
        if (m->state != autocal::CalibrationStatus::STATE_FAILED) return;
        const std::string why = "the simulator failed: " + m->failure_reason;
        ROS_ERROR("run_report_node: %s", why.c_str());
        recorder_->markInterrupted(why);
      });
  // Each wheel's reading as its driver stamped it: the recorder pairs the two wheels at one
  // instant (paired as they arrive, one would lag a reading behind and bend the path).
  encoders_ = std::make_unique<ros_layer::EncoderInput>(
      nh_, [](const ros::Time&, int, int, int) {}, &error_,
      [this](int side, const ros::Time& stamp, std::int32_t ticks, int tpr) {
        recorder_->addEncoderReading(side, stamp.toSec(), ticks, tpr);
      });
  // A reference pose (the simulator's true one, wired by its launch file), drawn beside the
  // believed path as the true path; no stage ever sees it. None on a robot.
  if (!options_.true_pose_topic.empty()) {
    true_pose_sub_ = nh_.subscribe<nav_msgs::Odometry>(
        options_.true_pose_topic, 50, [this](const nav_msgs::Odometry::ConstPtr& m) {
          recorder_->addTruePose(m->header.stamp.toSec(), ros_layer::fromPoseMsg(m->pose.pose));
        });
  }
  believed_path_pub_ = nh_.advertise<nav_msgs::Path>("calibration/believed_path", 1);

  // /diagnostics: one status per stage and one for the run, published
  // every ~diagnostic_period (diagnostic_updater's parameter, 1 s) of the node's clock.
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
  diagnostics_->setHardwareID(options_.veh);
  for (const std::string& stage : options_.stages) {
    diagnostics_->add(stage, [this, stage](diagnostic_updater::DiagnosticStatusWrapper& status) {
      stageDiagnostics(stage, status);
    });
  }
  diagnostics_->add("run", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    runDiagnostics(status);
  });
}

void RunReportNode::onStatus(const ros::MessageEvent<autocal::CalibrationStatus const>& event) {
  const autocal::CalibrationStatus& msg = *event.getMessage();
  const std::string stage = msg.phase.substr(0, msg.phase.find('/'));
  if (event.getPublisherName() == ros::this_node::getName()) return;  // our own
  recorder_->addStatus(ros_layer::fromStatusMsg(msg));
  stage_publisher_[stage] = event.getPublisherName();
  last_heard_[stage] = ros::Time::now();
}

void RunReportNode::stageDiagnostics(const std::string& stage,
                                     diagnostic_updater::DiagnosticStatusWrapper& status) {
  const StageRecord* s = recorder_->record().stage(stage);
  if (!s) return;
  const ros::Time now = ros::Time::now();
  const std::string current = recorder_->currentStage();
  if (current != diag_current_) {
    diag_current_ = current;
    diag_current_since_ = now;
  }
  // Silent since its last status, or since the run began waiting on it if that is later.
  ros::Time since = diag_current_since_;
  const auto heard = last_heard_.find(stage);
  if (heard != last_heard_.end() && heard->second > since) since = heard->second;
  const StageHealth h =
      stageHealth(*s, stage == current, (now - since).toSec(), options_.silent_warn_s);
  using Status = diagnostic_msgs::DiagnosticStatus;
  status.summary(h.level == StageHealth::Level::kError  ? Status::ERROR
                 : h.level == StageHealth::Level::kWarn ? Status::WARN
                                                        : Status::OK,
                 h.message);
  status.add("state", name(s->state));
  status.add("phase", s->phase);
  if (s->progress >= 0) status.add("progress", s->progress);
  if (!s->file.empty()) status.add("file", s->file);
  for (const auto& [key, value] : s->figures) status.add(key, value);
}

void RunReportNode::runDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const RunRecord& record = recorder_->record();
  using Status = diagnostic_msgs::DiagnosticStatus;
  if (!recorder_->ended()) {
    status.summary(Status::OK, "running: the " + recorder_->currentStage() + " stage");
  } else if (record.succeeded()) {
    status.summary(Status::OK, "succeeded");
  } else {
    status.summary(Status::ERROR, "failed: " + record.failure());
  }
  status.add("vehicle", record.vehicle);
  status.add("report_dir", options_.report_dir);
}

void RunReportNode::publishBelievedPath() {
  // Only for a watcher (RViz): the whole path is integrated again each time, at path_rate_hz.
  if (believed_path_pub_.getNumSubscribers() == 0) return;
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_path_).toSec() < 1.0 / options_.path_rate_hz) return;
  last_path_ = now;
  nav_msgs::Path msg;
  msg.header.frame_id = options_.odom_frame;
  msg.header.stamp = ros::Time::now();
  const ReportOptions& o = options_.report;
  for (const PathPoint& p : believedPath(recorder_->record(), o)) {
    geometry_msgs::PoseStamped pose;
    pose.header.frame_id = options_.odom_frame;
    pose.header.stamp = ros_layer::toRosTime(p.t_s);
    pose.pose = ros_layer::toPoseMsg(p.pose);
    msg.poses.push_back(pose);
  }
  believed_path_pub_.publish(msg);
}

void RunReportNode::checkStagesAlive() {
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_ping_).toSec() < options_.ping_period_s) return;
  last_ping_ = now;
  for (const StageRecord& s : recorder_->record().stages) {
    if (s.state != StageState::kRunning) continue;
    const auto it = stage_publisher_.find(s.stage);
    if (it == stage_publisher_.end()) continue;
    if (ros_layer::nodePid(it->second) > 0) {
      failed_pings_[s.stage] = 0;
      continue;
    }
    if (++failed_pings_[s.stage] < 2) continue;  // two in a row: not a busy moment
    const std::string why = it->second + " died while the stage was running (no DONE or FAILED)";
    recorder_->markStageDead(s.stage, why);
    // In the stage's name, so that a later stage waiting for its DONE gives up.
    status_.failed(s.stage + "/died", why);
    ROS_ERROR("run_report_node: %s: %s", s.stage.c_str(), why.c_str());
  }
  // A stage that never starts.
  const std::string current = recorder_->currentStage();
  if (current != waiting_for_) {
    waiting_for_ = current;
    waiting_since_ = ros::Time::now();
  }
  const StageRecord* s = recorder_->record().stage(current);
  if (s && s->state == StageState::kPending && options_.stage_start_timeout_s > 0 &&
      (ros::Time::now() - waiting_since_).toSec() > options_.stage_start_timeout_s) {
    const std::string why = "no status from the " + current + " stage within " +
                            formatNumber(options_.stage_start_timeout_s, 4) +
                            " s (~stage_start_timeout_s): is its node running?";
    recorder_->markStageDead(current, why);
    status_.failed(current + "/missing", why);
  }
}

void RunReportNode::printProgress() {
  for (const StageRecord& s : recorder_->record().stages) {
    if (s.state == StageState::kPending) continue;
    std::string line = s.phase + " " + name(s.state);
    if (s.progress >= 0 && s.state == StageState::kRunning)
      line += " " + std::to_string(static_cast<int>(100 * s.progress)) + " %";
    line += ": " + (s.state == StageState::kFailed ? s.failure : s.text);
    if (printed_[s.stage] == line) continue;
    // One line per stage and step: a new line when the step changes, else at most every 5 s.
    const bool same_step = printed_[s.stage].rfind(s.phase + " ", 0) == 0;
    if (same_step && s.state == StageState::kRunning) {
      ROS_INFO_THROTTLE(5.0, "run_report_node: [%s] %s", s.stage.c_str(), line.c_str());
    } else {
      ROS_INFO("run_report_node: [%s] %s", s.stage.c_str(), line.c_str());
    }
    printed_[s.stage] = line;
  }
}

ReportFiles RunReportNode::write() {
  if (options_.resume) {
    const std::string last = (fs::path(options_.report_dir) / "summary.yaml").string();
    for (const std::string& stage : options_.stages) {
      const PreviousStage p = previousStage(last, stage);
      if (p.done && !p.file.empty() && fs::exists(p.file))
        recorder_->keepFromLastRun(stage, p.file, p.figures);
    }
  }
  std::string warning;
  const ReportFiles files =
      writeRunReport(options_.report_dir, options_.calibration_root, options_.veh,
                     recorder_->record(), options_.report, &warning);
  if (!warning.empty()) ROS_WARN("run_report_node: %s", warning.c_str());
  return files;
}

void RunReportNode::run() {
  std::string stages;
  for (const std::string& s : options_.stages) stages += (stages.empty() ? "" : " -> ") + s;
  ROS_INFO("run_report_node: the run of %s: %s; the report goes to %s", options_.veh.c_str(),
           stages.c_str(), options_.report_dir.c_str());
  status_.running("run/watch", 0, "watching the run: " + stages);
  waiting_since_ = ros::Time::now();
  waiting_for_ = recorder_->currentStage();
  ros::WallRate rate(20);
  while (ros_layer::ok() && !recorder_->ended()) {
    ros::spinOnce();
    if (error_) std::rethrow_exception(error_);
    checkStagesAlive();
    printProgress();
    diagnostics_->update();
    publishBelievedPath();
    rate.sleep();
  }
  printProgress();
  if (!recorder_->ended()) recorder_->markInterrupted("interrupted before the run ended");
  // The run's end, at once (diagnostics are not latched: writing the report gives the message
  // time to go out before the node exits).
  diagnostics_->force_update();
  const ReportFiles files = write();
  const RunRecord& record = recorder_->record();
  ROS_INFO("run_report_node: wrote %s and %s", files.sheet_png.c_str(), files.summary_yaml.c_str());
  if (!record.succeeded()) {
    if (!ros_layer::ok()) return;  // interrupted: runNode reports it
    throw CalibrationError("the run failed: " + record.failure() + " (report " +
                           files.summary_yaml + ")");
  }
  status_.done("run/report", "wrote " + files.summary_yaml);
  ROS_INFO("run_report_node: the run succeeded");
}

}  // namespace report
}  // namespace autocal
