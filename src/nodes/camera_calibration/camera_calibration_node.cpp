#include "camera_calibration_node.h"

#include <cv_bridge/cv_bridge.h>
#include <ros/package.h>
#include <sensor_msgs/SetCameraInfo.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "autocal/camera/calibration_files.h"
#include "autocal/camera/debug_image.h"
#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace camera {

namespace fs = std::filesystem;

void CameraCalibrationNodeOptions::validate() const {
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(std::isfinite(camera_info_wait_s) && camera_info_wait_s >= 0,
                        "camera_info_wait_s", "must be >= 0");
  ros_layer::checkParam(board_square_m >= 0, "board_square_m", "must be > 0 (0: the config's)");
  ros_layer::checkLength("board_square_m", board_square_m, ranges::kBoardSquare);
  ros_layer::checkLength("nominal_wheel_radius_m", run.nominal_wheel_radius_m,
                         ranges::kWheelRadius);
  ros_layer::checkLength("nominal_wheelbase_m", run.nominal_wheelbase_m, ranges::kWheelbase);
  ros_layer::validateParams(run);
}

namespace {

CameraCalibrationNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "camera_calibration_node");
  CameraCalibrationNodeOptions o;
  o.stage = ros_layer::readStageNodeOptions(p, nh, 10);  // pulses are 0.1 s
  o.camera_config = ros::package::getPath("autocal") + "/config/camera_calibration.yaml";
  p.get("camera_config", o.camera_config);
  p.get("board_inner_corners", o.board_inner_corners);
  p.get("board_square_m", o.board_square_m);
  p.get("image_transport", o.image_transport);
  p.get("camera_info_wait_s", o.camera_info_wait_s);
  p.get("use_camera_info_guess", o.use_camera_info_guess);
  p.get("set_camera_info", o.set_camera_info);

  SweepRunOptions& r = o.run;
  p.get("probe_min_duty", r.probe_min_duty);
  p.get("min_duty", r.min_duty);
  p.get("probe_start_duty", r.probe.start_duty);
  p.get("probe_duty_step", r.probe.duty_step);
  p.get("probe_max_duty", r.probe.max_duty);
  p.get("probe_min_ticks", r.probe.min_ticks);
  p.get("target_step_rad", r.target_step_rad);
  p.get("max_step_duty", r.max_step_duty);
  p.get("nominal_wheel_radius_m", r.nominal_wheel_radius_m);
  p.get("nominal_wheelbase_m", r.nominal_wheelbase_m);
  p.get("still_s", r.still_s);
  p.get("max_image_speed_px_s", r.stillness.max_speed_px_s);
  p.get("max_still_wait_s", r.max_still_wait_s);
  p.get("camera_timeout_s", r.camera_timeout_s);
  p.get("encoder_timeout_s", r.encoder_timeout_s);
  p.get("max_duration_s", r.max_duration_s);
  p.get("min_views", r.min_views);
  std::vector<double> goal(r.coverage_goal.begin(), r.coverage_goal.end());
  p.get("coverage_goal", goal);
  if (goal.size() != r.coverage_goal.size())
    throw ConfigError("~coverage_goal: expected 6 spreads (x, y, size, skew, distance, tilt)");
  std::copy(goal.begin(), goal.end(), r.coverage_goal.begin());
  p.get("calibrate_on_sharp_views", r.calibrate_on_sharp_views);
  p.get("refine_rounds", r.refine_rounds);
  p.get("refine_spread_rad", r.refine_spread_rad);
  p.get("refine_tolerance_rad", r.refine_tolerance_rad);
  p.get("refine_max_steps", r.refine_max_steps);
  p.get("refine_max_s", r.refine_max_s);

  SweepOptions& s = r.sweep;
  p.get("board_count", s.board_count);
  p.get("start_board", s.start_board);
  std::string direction = name(s.initial_direction), pivot = name(s.pivot);
  p.get("initial_direction", direction);
  if (direction != "cw" && direction != "ccw")
    throw ConfigError("~initial_direction: must be 'cw' or 'ccw', not '" + direction + "'");
  s.initial_direction = direction == "cw" ? TurnDirection::kCw : TurnDirection::kCcw;
  p.get("pivot", pivot);
  try {
    s.pivot = parsePivotConvention(pivot);
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("~pivot: ") + e.what());
  }
  p.get("max_passes", s.max_passes);
  p.get("min_steps", s.min_steps);
  p.get("camera_hfov_rad", s.camera_hfov_rad);
  p.get("max_gap_rad", s.max_gap_rad);
  p.get("full_turn_rad", s.full_turn_rad);
  p.get("step_duration_s", s.step_duration_s);
  p.get("step_duty_margin", s.step_duty_margin);
  p.get("settle_s", s.settle_s);
  p.get("max_settle_s", s.max_settle_s);
  o.validate();
  // The output folder, before the robot moves (the file is written after the whole sweep).
  checkWritableFolder((fs::path(o.stage.calibration_root) / "camera_intrinsic").string());
  return o;
}

CameraCalibrationConfig loadCamera(const CameraCalibrationNodeOptions& o) {
  return loadStageCameraConfig(o.camera_config, o.board_inner_corners, o.board_square_m);
}

ros_layer::StageInputs stageInputs(const CameraCalibrationNodeOptions& o) {
  ros_layer::StageInputs in;
  in.image_transport = o.image_transport;
  return in;
}

}  // namespace

CameraCalibrationNode::CameraCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readOptions(nh, pnh)),
      camera_(loadCamera(options_)),
      node_(nh, "camera_calibration_node", "camera", options_.stage, stageInputs(options_),
            "waiting for the camera and the encoders") {
  debug_pub_ = pnh_.advertise<sensor_msgs::CompressedImage>("debug/image/compressed", 1);
  info_sub_ = nh_.subscribe<sensor_msgs::CameraInfo>(
      "camera_node/camera_info", 1, [this](const sensor_msgs::CameraInfo::ConstPtr& msg) {
        if (have_info_) return;
        info_ = *msg;
        have_info_ = true;
      });
}

void CameraCalibrationNode::publishDebug(const cv::Mat& frame) {
  if (debug_pub_.getNumSubscribers() == 0) return;
  const SweepFrameReport& last = run_->lastFrame();
  const cv::Mat img =
      drawSweepDebugImage(frame, last.frame, run_->collector().coverage(), run_->describe());
  sensor_msgs::CompressedImage msg;
  msg.header.stamp = ros_layer::toRosTime(last.stamp_s);
  msg.format = "jpeg";
  cv::imencode(".jpg", img, msg.data, {cv::IMWRITE_JPEG_QUALITY, 80});
  debug_pub_.publish(msg);
}

void CameraCalibrationNode::waitForCameraInfo() {
  const ros::Time start = ros::Time::now();
  ros::Rate rate(options_.stage.control_rate_hz);
  while (ros_layer::ok() && !have_info_ &&
         (ros::Time::now() - start).toSec() < options_.camera_info_wait_s) {
    ros::spinOnce();
    if (*node_.error()) std::rethrow_exception(*node_.error());
    rate.sleep();
  }
}

std::pair<CameraCalibrationConfig, SweepRunOptions> CameraCalibrationNode::stageSetup() {
  CameraCalibrationConfig camera = camera_;
  SweepRunOptions run = options_.run;
  if (have_info_) {
    const CameraIntrinsics nominal = ros_layer::fromCameraInfo(info_);
    useNominalCamera(nominal, options_.use_camera_info_guess, camera, run);
    ROS_INFO("camera_calibration_node: camera_info: %dx%d, fx %.1f: field of view %.2f rad%s",
             nominal.width, nominal.height, nominal.fx, run.sweep.camera_hfov_rad,
             options_.use_camera_info_guess ? ", the fit starts from it" : "");
    const cv::Size size(info_.width, info_.height);
    node_.holdFramesToSize(size);
  } else {
    ROS_WARN(
        "camera_calibration_node: no camera_info in %.1f s: field of view %.2f rad "
        "(~camera_hfov_rad), the fit starts from OpenCV's own guess",
        options_.camera_info_wait_s, run.sweep.camera_hfov_rad);
  }
  return {camera, run};
}

std::unique_ptr<Stage> CameraCalibrationNode::build() {
  const auto setup = stageSetup();
  auto run = std::make_unique<SweepRun>(setup.second, setup.first);
  run->setCameraInfoFormat(ros_layer::cameraInfoYaml);
  run_ = run.get();
  return run;
}

void CameraCalibrationNode::setCameraInfo(const CameraIntrinsics& intrinsics,
                                          const std::string& path) {
  ros::ServiceClient client =
      nh_.serviceClient<sensor_msgs::SetCameraInfo>("camera_node/set_camera_info");
  sensor_msgs::SetCameraInfo srv;
  srv.request.camera_info = ros_layer::toCameraInfo(intrinsics);
  if (!client.waitForExistence(ros::Duration(2.0)) || !client.call(srv) || !srv.response.success) {
    // The file is written: the camera node reads it at its next start.
    ROS_WARN("camera_calibration_node: camera_node/set_camera_info failed (%s); %s is written",
             srv.response.status_message.c_str(), path.c_str());
  }
}

void CameraCalibrationNode::run() {
  ros_layer::StageNode::Hooks hooks;
  hooks.inputs_connected = [this] { return info_sub_.getNumPublishers() > 0; };
  hooks.before_build = [this] { waitForCameraInfo(); };
  hooks.after_frame = [this](double, const cv::Mat& frame) { publishDebug(frame); };
  hooks.after_finish = [this](StageResult& result) {
    if (options_.set_camera_info) setCameraInfo(run_->calibration().intrinsics, result.file);
  };
  node_.run([this](int) { return build(); }, hooks);
}

}  // namespace camera
}  // namespace autocal
