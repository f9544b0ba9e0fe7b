#include "wheel_calibration_node.h"

#include <camera_calibration_parsers/parse.h>

#include <cmath>
#include <filesystem>

#include "autocal/errors.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/atomic_file.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"
#include "autocal_ros/tag_params.h"

namespace autocal {
namespace wheels {

void WheelCalibrationNodeOptions::validate() const {
  ros_layer::checkLength("tag_size_m", run.detector.tag_size_m, ranges::kTagSize);
  ros_layer::checkLength("camera_height_m", run.mount.height_m, ranges::kCameraHeight);
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(std::isfinite(camera_stage_wait_s) && camera_stage_wait_s >= 0,
                        "camera_stage_wait_s", "must be >= 0");
  ros_layer::checkParam(std::isfinite(deadband_guess) && deadband_guess < 0.9, "deadband_guess",
                        "must be < 0.9 (negative: automatic)");
  ros_layer::checkParam(std::isfinite(deadband_guess_resolution) &&
                            deadband_guess_resolution >= 0 && deadband_guess_resolution < 0.5,
                        "deadband_guess_resolution", "must be in [0, 0.5) (0: each its own)");
  ros_layer::validateParams(run);
}

namespace {

WheelCalibrationNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "wheel_calibration_node");
  WheelCalibrationNodeOptions o;
  o.stage = ros_layer::readStageNodeOptions(p, nh, 20);
  p.get("intrinsics_file", o.intrinsics_file);
  p.get("camera_stage_wait_s", o.camera_stage_wait_s);
  p.get("image_transport", o.image_transport);
  p.get("update_kinematics_node", o.update_kinematics_node);
  p.get("deadband_guess", o.deadband_guess);
  p.get("deadband_guess_resolution", o.deadband_guess_resolution);

  WheelRunOptions& r = o.run;
  ros_layer::readTagParams(p, r.detector, r.heading, r.mount);
  p.get("min_update", r.trim.min_update);
  p.get("ignored_to_converge", r.trim.ignored_to_converge);
  p.get("damping", r.trim.damping);
  p.get("full_step_above", r.trim.full_step_above);
  p.get("max_iterations", r.trim.max_iterations);
  p.get("mean_of_drives", r.trim.mean_of_drives);
  p.get("max_mean_error", r.trim.max_mean_error);
  p.get("more_drives_for_mean", r.trim.more_drives_for_mean);
  p.get("compensate_deadband", r.compensate_deadband);
  p.get("drive_speed_mps", r.drive_speed_mps);
  p.get("back_speed_mps", r.back_speed_mps);
  p.get("back_steer_s", r.back_steer_s);
  p.get("max_back_steer", r.max_back_steer);
  p.get("max_fit_cycles", r.max_fit_cycles);
  p.get("drive_s", r.drive_s);
  p.get("min_drive_s", r.min_drive_s);
  p.get("max_drive_turn_rad", r.max_drive_turn_rad);
  p.get("align_tolerance_rad", r.align_tolerance_rad);
  p.get("realign_above_rad", r.realign_above_rad);
  p.get("turn_duty_margin", r.turn_duty_margin);
  p.get("max_search_turn_rad", r.max_search_turn_rad);
  p.get("heading_frames", r.heading_frames);
  p.get("leave_speed_mps", r.leave_speed_mps);
  p.get("leave_clear_s", r.leave_clear_s);
  p.get("exit_extra_m", r.exit_extra_m);
  p.get("max_leave_m", r.max_leave_m);
  p.get("leave_lateral_gain_rad_per_m", r.leave_lateral_gain_rad_per_m);
  p.get("leave_max_correction_rad", r.leave_max_correction_rad);
  p.get("leave_heading_gain_per_s", r.leave_heading_gain_per_s);
  p.get("camera_timeout_s", r.camera_timeout_s);
  p.get("encoder_timeout_s", r.encoder_timeout_s);
  p.get("max_duration_s", r.max_duration_s);
  r.extrinsics_spins = 4;  // the node writes the camera's extrinsics by default
  p.get("extrinsics_spins", r.extrinsics_spins);
  p.get("extrinsics_spin_rad", r.extrinsics_spin_rad);
  p.get("extrinsics_drive_m", r.extrinsics_drive_m);
  p.get("extrinsics_drives", r.extrinsics_drives);
  p.get("extrinsics_drives_back", r.extrinsics_drives_back);
  p.get("extrinsics_passes", r.extrinsics_passes);
  p.get("extrinsics_max_passes", r.extrinsics_max_passes);
  p.get("extrinsics_min_hops", r.extrinsics_min_hops);
  p.get("extrinsics_max_floor_sigma_m", r.extrinsics_max_floor_sigma_m);
  p.get("extrinsics_max_yaw_sigma_rad", r.extrinsics_max_yaw_sigma_rad);
  o.validate();
  // The output folders, before the robot moves (the files are written after the last drive).
  checkWritableFolder(std::filesystem::path(kinematicsPath(o.stage.calibration_root, o.stage.veh))
                          .parent_path()
                          .string());
  if (r.extrinsics_spins > 0)
    checkWritableFolder(
        std::filesystem::path(extrinsics::extrinsicsPath(o.stage.calibration_root, o.stage.veh))
            .parent_path()
            .string());
  return o;
}

/// The StageNode's options: the wait for the camera stage unless the intrinsics are given.
ros_layer::StageNodeOptions stageOptions(const WheelCalibrationNodeOptions& o) {
  ros_layer::StageNodeOptions stage = o.stage;
  if (o.intrinsics_file.empty()) stage.after_stage = "camera";
  stage.after_stage_wait_s = o.camera_stage_wait_s;
  return stage;
}

ros_layer::StageInputs stageInputs(const WheelCalibrationNodeOptions& o) {
  ros_layer::StageInputs in;
  in.image_transport = o.image_transport;
  in.pair_encoders = true;
  return in;
}

double figure(const autocal::CalibrationStatus& msg, const std::string& name) {
  for (size_t i = 0; i < msg.figure_names.size() && i < msg.figure_values.size(); ++i)
    if (msg.figure_names[i] == name) return msg.figure_values[i];
  return -1;
}

/// The file the camera stage's DONE carries (written, or kept by a resumed run).
std::string fileOfDone(const autocal::CalibrationStatus& done) {
  if (done.file.empty())
    throw CalibrationError("the camera stage's DONE names no file (\"" + done.text +
                           "\"), and no ~intrinsics_file");
  return done.file;
}

}  // namespace

WheelCalibrationNode::WheelCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readOptions(nh, pnh)),
      before_(readKinematicsFileOrDefaults(  // a malformed file is an error
          kinematicsPath(options_.stage.calibration_root, options_.stage.veh))),
      kinematics_path_(kinematicsPath(options_.stage.calibration_root, options_.stage.veh)),
      node_(nh, "wheel_calibration_node", "wheels", stageOptions(options_), stageInputs(options_),
            options_.intrinsics_file.empty() ? "waiting for the camera stage"
                                             : "waiting for the camera and the encoders") {
  // Given intrinsics that cannot be read fail before anything else.
  if (!options_.intrinsics_file.empty()) readIntrinsics();
  detections_pub_ =
      nh_.advertise<dtmsg::AprilTagDetectionArray>("apriltag_detector_node/detections", 5);
}

void WheelCalibrationNode::publishDetections(double stamp_s) {
  if (detections_pub_.getNumSubscribers() == 0) return;
  dtmsg::AprilTagDetectionArray msg;
  msg.header.stamp = ros_layer::toRosTime(stamp_s);
  for (const auto& d : run_->lastDetections())
    msg.detections.push_back(ros_layer::toTagDetectionMsg(d));
  detections_pub_.publish(msg);
}

void WheelCalibrationNode::run() {
  ros_layer::StageNode::Hooks hooks;
  hooks.after_frame = [this](double stamp_s, const cv::Mat&) { publishDetections(stamp_s); };
  hooks.after_finish = [this](StageResult&) {
    if (options_.run.extrinsics_spins > 0 && !run_->extrinsicsResult())
      ROS_WARN("wheel_calibration_node: no camera extrinsics written: %s",
               run_->extrinsicsFailure().c_str());
    if (!options_.update_kinematics_node) return;
    // The running kinematics node polls its parameters: the new trim applies without a restart.
    const KinematicsParams k = run_->result();
    nh_.setParam("kinematics_node/trim", k.trim);
    nh_.setParam("kinematics_node/deadband_left", k.deadband_left);
    nh_.setParam("kinematics_node/deadband_right", k.deadband_right);
  };
  node_.run([this](int) { return build(); }, hooks);
}

std::unique_ptr<Stage> WheelCalibrationNode::build() {
  double camera_min_duty_left = -1, camera_min_duty_right = -1;
  if (options_.intrinsics_file.empty()) {
    const autocal::CalibrationStatus& done = node_.afterStageDone();
    options_.intrinsics_file = fileOfDone(done);
    camera_min_duty_left = figure(done, "min_duty_left_forward");
    camera_min_duty_right = figure(done, "min_duty_right_forward");
  }
  const CameraIntrinsics intrinsics = readIntrinsics();
  WheelRunOptions r = options_.run;
  r.kinematics = before_;
  r.intrinsics_file = options_.intrinsics_file;
  const DeadbandGuesses g =
      firstDeadbandGuesses(options_.deadband_guess, camera_min_duty_left, camera_min_duty_right,
                           options_.deadband_guess_resolution, before_);
  r.kinematics.deadband_left = g.left;
  r.kinematics.deadband_right = g.right;
  ROS_INFO(
      "wheel_calibration_node: intrinsics %s (fx %.1f), kinematics %s, deadband guess %.3f/%.3f",
      options_.intrinsics_file.c_str(), intrinsics.fx, kinematics_path_.c_str(), g.left, g.right);
  auto run = std::make_unique<WheelRun>(r, intrinsics);
  node_.holdFramesToSize(intrinsics.imageSize());
  run_ = run.get();
  return run;
}

CameraIntrinsics WheelCalibrationNode::readIntrinsics() const {
  return ros_layer::readIntrinsicsFile(options_.intrinsics_file,
                                       "the wheel stage needs the calibrated camera");
}

}  // namespace wheels
}  // namespace autocal
