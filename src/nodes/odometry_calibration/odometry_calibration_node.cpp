#include "odometry_calibration_node.h"

#include <geometry_msgs/Point.h>
#include <std_msgs/Float64.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace odometry {

void OdometryCalibrationNodeOptions::validate() const {
  ros_layer::checkParam(std::isfinite(wheel_radius_m) && wheel_radius_m > 0, "wheel_radius_m",
                        "must be > 0 [m]");
  ros_layer::checkParam(std::isfinite(wheelbase_m) && wheelbase_m > 0, "wheelbase_m",
                        "must be > 0 [m]");
  ros_layer::checkLength("wheel_radius_m", wheel_radius_m, ranges::kWheelRadius);
  ros_layer::checkLength("wheelbase_m", wheelbase_m, ranges::kWheelbase);
  if (method == "umbmark") ros_layer::checkLength("side_m", umbmark.side_m, ranges::kUmbmarkSide);
  if (method == "uah")
    ros_layer::checkLength("straight_length_m", run.straight_length_m, ranges::kStraightRun);
  ros_layer::checkParam(ticks_per_revolution >= 0, "ticks_per_revolution",
                        "must be >= 0 (0: from the encoder messages)");
  ros_layer::checkParam(method == "uah" || method == "umbmark", "method",
                        "must be uah or umbmark, got '" + method + "'");
  ros_layer::checkParam(
      stage.after_stage.empty() || stage.after_stage == "camera" || stage.after_stage == "wheels",
      "after_stage", "must be empty, camera or wheels, got '" + stage.after_stage + "'");
  ros_layer::checkParam(std::isfinite(stage.after_stage_wait_s) && stage.after_stage_wait_s >= 0,
                        "after_stage_wait_s", "must be >= 0 [s]");
  UahRunOptions r = run;
  r.nominal = DiffDriveParams::fromWheel(2 * wheel_radius_m, 100, wheelbase_m);  // set later
  ros_layer::validateParams(r);
  UmbmarkRunOptions u = umbmark;
  u.nominal = r.nominal;
  ros_layer::validateParams(u);
}

namespace {

OdometryCalibrationNodeOptions checked(const OdometryCalibrationNodeOptions& o) {
  o.validate();
  // The output folder, before the robot moves (the file is written after the last experiment).
  checkWritableFolder(
      std::filesystem::path(odometryCalibrationPath(o.stage.calibration_root, o.stage.veh))
          .parent_path()
          .string());
  return o;
}

/// The drive's keys, which both methods have.
void readDrive(const ros_layer::ParamReader& p, EncoderDriveOptions& d) {
  p.get("start_duty", d.start_duty);
  p.get("max_duty", d.max_duty);
  p.get("stall_s", d.stall_s);
  p.get("encoder_timeout_s", d.encoder_timeout_s);
}

OdometryCalibrationNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "odometry_calibration_node");
  OdometryCalibrationNodeOptions o;
  o.stage = ros_layer::readStageNodeOptions(p, nh, 20);
  p.get("after_stage", o.stage.after_stage);
  p.get("after_stage_wait_s", o.stage.after_stage_wait_s);
  p.get("wheel_radius_m", o.wheel_radius_m);
  p.get("wheelbase_m", o.wheelbase_m);
  p.get("ticks_per_revolution", o.ticks_per_revolution);
  p.get("method", o.method);
  // Only the chosen method's keys are read (and echoed); the rest keep their defaults.
  if (o.method == "umbmark") {
    UmbmarkRunOptions& u = o.umbmark;
    p.get("side_m", u.side_m);
    p.get("runs_per_direction", u.runs_per_direction);
    std::string expressions = toString(u.expressions);
    p.get("expressions", expressions);
    try {
      u.expressions = umbmarkExpressionsFromName(expressions);
    } catch (const ConfigError&) {
      ros_layer::checkParam(false, "expressions", "must be original or corrected");
    }
    p.get("drive_rate_pulses_per_s", u.drive_rate_pulses_per_s);
    p.get("turn_rate_pulses_per_s", u.turn_rate_pulses_per_s);
    readDrive(p, u);
    p.get("max_return_error_fraction", u.max_return_error_fraction);
    p.get("error_timeout_s", u.error_timeout_s);
    p.get("max_duration_s", u.max_duration_s);
    p.get("errors_file", u.errors_file);
    u.errors_after_all = !u.errors_file.empty();
    if (u.errors_after_all) u.errors_source = u.errors_file;
    if (u.errors_after_all) p.get("run_pause_s", u.run_pause_s);
    return checked(o);
  }
  UahRunOptions& r = o.run;
  p.get("rounds", r.rounds);
  p.get("pivot_experiments", r.pivot_experiments);
  p.get("pivot_rate_pulses_per_s", r.pivot_rate_pulses_per_s);
  p.get("spin_rate_pulses_per_s", r.spin_rate_pulses_per_s);
  p.get("straight_rate_pulses_per_s", r.straight_rate_pulses_per_s);
  p.get("straight_fast_rate_pulses_per_s", r.straight_fast_rate_pulses_per_s);
  readDrive(p, r);
  p.get("straight_length_m", r.straight_length_m);
  p.get("straight_runs", r.straight_runs);
  p.get("max_straight_retries", r.max_straight_retries);
  p.get("max_heading_deviation_rad", r.straight.max_heading_deviation_rad);
  p.get("max_straight_shortening", r.straight.max_shortening);
  p.get("max_straight_disagreement", r.straight.max_disagreement);
  p.get("face_tolerance_rad", r.face_tolerance_rad);
  p.get("max_face_turns", r.max_face_turns);
  p.get("min_clearance_m", r.min_clearance_m);
  p.get("max_trim_disagreement", r.max_trim_disagreement);
  p.get("window_fraction", r.detection.window_fraction);
  p.get("min_peak_correlation", r.detection.min_peak_correlation);
  p.get("max_secondary_ratio", r.detection.max_secondary_ratio);
  p.get("min_range_spread_m", r.min_range_spread_m);
  p.get("max_invalid_range_fraction", r.max_invalid_range_fraction);
  p.get("range_timeout_s", r.range_timeout_s);
  p.get("length_timeout_s", r.length_timeout_s);
  p.get("max_duration_s", r.max_duration_s);
  return checked(o);
}

ros_layer::StageInputs stageInputs(const OdometryCalibrationNodeOptions& o) {
  ros_layer::StageInputs in;
  in.ranges = o.method == "uah";
  // Each wheel's count with the other's at the same instant: a robot's two encoder messages come
  // apart, and the straight runs' heading control and check would see turns that did not happen.
  in.pair_encoders = true;
  // The stage is built at the first encoder reading: the nominal robot needs its resolution.
  in.first_encoders_wait_s =
      (o.method == "umbmark" ? o.umbmark.encoder_timeout_s : o.run.encoder_timeout_s) +
      o.stage.connect_wait_s;
  return in;
}

}  // namespace

OdometryCalibrationNode::OdometryCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : pnh_(pnh),
      options_(readOptions(nh, pnh)),
      node_(nh, "odometry_calibration_node", "odometry", options_.stage, stageInputs(options_),
            "waiting for the encoders and the range sensor") {}

std::unique_ptr<Stage> OdometryCalibrationNode::build(int ticks_per_revolution) {
  const int resolution =
      options_.ticks_per_revolution > 0 ? options_.ticks_per_revolution : ticks_per_revolution;
  const DiffDriveParams nominal =
      DiffDriveParams::fromWheel(2 * options_.wheel_radius_m, resolution, options_.wheelbase_m);
  std::unique_ptr<Stage> stage;
  std::string plan;
  if (umbmark()) {
    UmbmarkRunOptions u = options_.umbmark;
    u.nominal = nominal;
    plan = "UMBmark: " + u.summary();
    stage = std::make_unique<UmbmarkRun>(u);
    umbmark_ = static_cast<UmbmarkRun*>(stage.get());
  } else {
    UahRunOptions r = options_.run;
    r.nominal = nominal;
    plan = "UAH: " + r.summary();
    stage = std::make_unique<UahRun>(r);
    uah_ = static_cast<UahRun*>(stage.get());
  }
  ROS_INFO(
      "odometry_calibration_node: nominal radius %.4f m, wheelbase %.4f m, %d ticks/rev; %s; "
      "calibration root %s",
      options_.wheel_radius_m, options_.wheelbase_m, resolution, plan.c_str(),
      options_.stage.calibration_root.c_str());
  return stage;
}

void OdometryCalibrationNode::run() {
  error_sub_ = pnh_.subscribe<geometry_msgs::Point>(
      "return_error", 5,
      [this](const geometry_msgs::Point::ConstPtr& msg) { onReturnError(msg->x, msg->y); });
  length_sub_ = pnh_.subscribe<std_msgs::Float64>(
      "straight_length", 5,
      [this](const std_msgs::Float64::ConstPtr& msg) { onStraightLength(msg->data); });
  node_.run([this](int ticks_per_revolution) { return build(ticks_per_revolution); });
}

void OdometryCalibrationNode::onReturnError(double x_m, double y_m) {
  const std::string which = umbmark_ ? std::string(name(umbmark_->phase())) + " run " +
                                           std::to_string(umbmark_->runInDirection())
                                     : "";
  if (node_.hand("a return error (" + formatNumber(x_m, 4) + ", " + formatNumber(y_m, 4) + ") m",
                 umbmark_ && umbmark_->needsReturnError(), [&] {
                   umbmark_->setReturnError({x_m, y_m});
                 })) {
    ROS_INFO("odometry_calibration_node: %s: return error (%.4f, %.4f) m", which.c_str(), x_m, y_m);
  }
}

void OdometryCalibrationNode::onStraightLength(double length_m) {
  const int run = uah_ ? uah_->straightRun() : 0;
  if (!node_.hand("a straight length (" + formatNumber(length_m, 4) + " m)",
                  uah_ && uah_->needsStraightLength(),
                  [&] { uah_->setStraightLength(length_m); })) {
    return;
  }
  const std::vector<StraightRun>& runs = uah_->straightRuns();
  const StraightRun& last = runs.back();
  bool accepted = false;
  try {
    const MmPerPulseEstimate e = estimateMmPerPulse(runs, options_.run.straight);
    accepted = std::find(e.accepted_runs.begin(), e.accepted_runs.end(),
                         static_cast<int>(runs.size()) - 1) != e.accepted_runs.end();
  } catch (const CalibrationError&) {
    // none accepted
  }
  ROS_INFO(
      "odometry_calibration_node: straight run %d: %.4f m given, %.0f right pulses, heading "
      "deviated %.2f deg, shortened %.3f %% (%s)",
      run, last.length_m, last.right_pulses, last.max_heading_deviation_rad * 180 / M_PI,
      100 * last.shortening, accepted ? "accepted" : "rejected");
}

}  // namespace odometry
}  // namespace autocal
