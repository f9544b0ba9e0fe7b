#include "lane_refinement_node.h"

#include <camera_calibration_parsers/parse.h>
#include <std_srvs/Empty.h>

#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"
#include "autocal_ros/tag_params.h"

namespace autocal {
namespace wheels {

void LaneRefinementNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkParam(!calibration_root.empty(), "calibration_root", "must not be empty");
  ros_layer::checkLength("tag_size_m", refiner.detector.tag_size_m, ranges::kTagSize);
  ros_layer::checkLength("camera_height_m", refiner.mount.height_m, ranges::kCameraHeight);
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(std::isfinite(control_rate_hz) && control_rate_hz >= 10, "control_rate_hz",
                        "must be >= 10 Hz");
  ros_layer::checkParam(std::isfinite(status_rate_hz) && status_rate_hz > 0, "status_rate_hz",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(service_wait_s) && service_wait_s >= 0, "service_wait_s",
                        "must be >= 0");
  ros_layer::checkParam(std::isfinite(trim_poll_s) && trim_poll_s > 0, "trim_poll_s",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(max_duration_s) && max_duration_s >= 0, "max_duration_s",
                        "must be >= 0");
  ros_layer::validateParams(refiner);
}

namespace {

LaneRefinementNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "lane_refinement_node");
  LaneRefinementNodeOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("intrinsics_file", o.intrinsics_file);
  p.get("image_transport", o.image_transport);
  p.get("control_rate_hz", o.control_rate_hz);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("stop_after_pass", o.stop_after_pass);
  p.get("save_calibration", o.save_calibration);
  p.get("service_wait_s", o.service_wait_s);
  p.get("trim_poll_s", o.trim_poll_s);
  p.get("max_duration_s", o.max_duration_s);

  LaneRefinerOptions& r = o.refiner;
  ros_layer::readTagParams(p, r.detector, r.heading, r.mount);
  p.get("first_tag_id", r.first_tag_id);
  p.get("num_tags", r.num_tags);
  p.get("start_max_distance_m", r.start_max_distance_m);
  p.get("start_max_heading_rad", r.start_max_heading_rad);
  p.get("start_max_lateral_m", r.start_max_lateral_m);
  p.get("speed_mps", r.speed_mps);
  p.get("heading_gain_per_s", r.heading_gain_per_s);
  p.get("max_omega_radps", r.max_omega_radps);
  p.get("orient_tolerance_rad", r.orient_tolerance_rad);
  p.get("max_orient_s", r.max_orient_s);
  p.get("lateral_gain_rad_per_m", r.lateral_gain_rad_per_m);
  p.get("max_lateral_correction_rad", r.max_lateral_correction_rad);
  p.get("settle_s", r.settle_s);
  p.get("straight_m", r.straight_m);
  p.get("max_straight_deviation_rad", r.max_straight_deviation_rad);
  p.get("min_frames_per_part", r.min_frames_per_part);
  p.get("min_part_m", r.min_part_m);
  p.get("max_part_deviation", r.max_part_deviation);
  p.get("min_parts_per_pass", r.min_parts_per_pass);
  p.get("max_heading_rad", r.max_heading_rad);
  p.get("tags_lost_s", r.tags_lost_s);
  p.get("max_pass_s", r.max_pass_s);
  p.get("stable_passes", r.stable_passes);
  p.get("stable_tolerance", r.stable_tolerance);
  p.get("apply_threshold", r.apply_threshold);
  p.get("drive_to_first_tag", r.drive_to_first_tag);
  o.validate();
  return o;
}

}  // namespace

LaneRefinementNode::LaneRefinementNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), options_(readOptions(nh, pnh)) {
  kinematics_path_ = kinematicsPath(options_.calibration_root, options_.veh);
  // The kinematics the robot drives with: the file, and the running node's trim when it is set
  // (it may differ from the file until saved).
  options_.refiner.kinematics = readKinematicsFileOrDefaults(kinematics_path_);
  double trim = 0;
  if (nh_.getParam("kinematics_node/trim", trim)) options_.refiner.kinematics.trim = trim;
  trim_before_ = options_.refiner.kinematics.trim;
  if (options_.intrinsics_file.empty())
    options_.intrinsics_file =
        options_.calibration_root + "/camera_intrinsic/" + options_.veh + ".yaml";
  status_ = ros_layer::StatusPublisher(nh_, "calibration/status");
  car_cmd_pub_ = nh_.advertise<dtmsg::Twist2DStamped>("kinematics_node/car_cmd", 10);
  detections_pub_ =
      nh_.advertise<dtmsg::AprilTagDetectionArray>("apriltag_detector_node/detections", 5);
}

void LaneRefinementNode::command(const CarCommand& cmd) {
  car_cmd_pub_.publish(ros_layer::toCarCmd(cmd, ros::Time::now()));
}

void LaneRefinementNode::apply(double trim) {
  // The running kinematics node polls its parameters: the new trim applies without a restart.
  nh_.setParam("kinematics_node/trim", trim);
  ROS_INFO("lane_refinement_node: applied trim %.5f (was %.5f): %s", trim, trim_before_,
           refiner_->describe().c_str());
  if (options_.save_calibration) {
    ros::ServiceClient save =
        nh_.serviceClient<std_srvs::Empty>("kinematics_node/save_calibration");
    std_srvs::Empty srv;
    if (!save.waitForExistence(ros::Duration(options_.service_wait_s)) || !save.call(srv)) {
      // The trim is in use; only the file is not updated (the kinematics node logs why).
      ROS_ERROR("lane_refinement_node: %s failed: the new trim is in use but not saved",
                save.getService().c_str());
    }
  }
  status_.running(
      "lane/applied", -1,
      "applied trim " + formatNumber(trim, 5) + " (was " + formatNumber(trim_before_, 5) + ")",
      {{"trim", trim},
       {"trim_before", trim_before_},
       {"passes", static_cast<double>(refiner_->passes().size())},
       {"applications", static_cast<double>(refiner_->applications())}});
  last_phase_ = "lane/applied";
  last_status_ = ros::Time::now();
  trim_before_ = trim;
}

void LaneRefinementNode::pollTrim(double now_s) {
  if (refiner_->inPass() || now_s - last_trim_poll_s_ < options_.trim_poll_s) return;
  last_trim_poll_s_ = now_s;
  double trim = 0;
  if (nh_.getParam("kinematics_node/trim", trim) && std::isfinite(trim) &&
      trim != refiner_->currentTrim()) {
    try {
      refiner_->setCurrentTrim(trim);
      trim_before_ = trim;
      ROS_INFO("lane_refinement_node: kinematics_node/trim is now %.5f", trim);
    } catch (const ConfigError& e) {
      ROS_WARN_THROTTLE(10, "lane_refinement_node: ignoring kinematics_node/trim %.5f: %s", trim,
                        e.what());
    }
  }
}

void LaneRefinementNode::publishDetections(const ros::Time& stamp) {
  if (detections_pub_.getNumSubscribers() == 0) return;
  dtmsg::AprilTagDetectionArray msg;
  msg.header.stamp = stamp;
  for (const auto& d : refiner_->lastDetections())
    msg.detections.push_back(ros_layer::toTagDetectionMsg(d));
  detections_pub_.publish(msg);
}

void LaneRefinementNode::publishStatus(bool force) {
  const std::string phase = refiner_->inPass() ? "lane/pass" : "lane/idle";
  const ros::Time now = ros::Time::now();
  if (!force && (phase == last_phase_ || last_phase_ == "lane/applied") &&
      (now - last_status_).toSec() < 1.0 / options_.status_rate_hz)
    return;
  if (phase != last_phase_ || refiner_->passes().size() != last_passes_)
    ROS_INFO("lane_refinement_node: %s: %s", phase.c_str(), refiner_->describe().c_str());
  last_phase_ = phase;
  last_status_ = now;
  last_passes_ = refiner_->passes().size();
  const auto& passes = refiner_->passes();
  const double last_estimate =
      !passes.empty() && passes.back().estimated ? passes.back().estimate : std::nan("");
  status_.running(phase, -1, refiner_->describe(),
                  {{"trim", refiner_->currentTrim()},
                   {"passes", static_cast<double>(passes.size())},
                   {"applications", static_cast<double>(refiner_->applications())},
                   {"last_estimate", std::isfinite(last_estimate) ? last_estimate : 0.0},
                   {"last_pass_aborted", !passes.empty() && passes.back().aborted ? 1.0 : 0.0},
                   {"frames_dropped", static_cast<double>(frames_->dropped())}});
}

void LaneRefinementNode::run() {
  sensor_msgs::CameraInfo info;
  std::string camera_name;
  if (!camera_calibration_parsers::readCalibration(options_.intrinsics_file, camera_name, info) ||
      info.K[0] <= 0) {
    throw ConfigError("the camera intrinsics '" + options_.intrinsics_file +
                      "' cannot be read (~intrinsics_file; the refinement needs the calibrated "
                      "camera)");
  }
  const CameraIntrinsics intrinsics = ros_layer::fromCameraInfo(info);
  refiner_ = std::make_unique<LaneRefiner>(options_.refiner, intrinsics);
  ROS_INFO("lane_refinement_node: intrinsics %s (fx %.1f), kinematics %s (trim %.5f), first tag %d",
           options_.intrinsics_file.c_str(), intrinsics.fx, kinematics_path_.c_str(),
           options_.refiner.kinematics.trim, options_.refiner.first_tag_id);
  frames_ = std::make_unique<ros_layer::FrameInput>(
      nh_, options_.image_transport, "lane_refinement_node", [](const ros::Time&) { return true; },
      [this](const ros::Time& stamp, const cv::Mat& image, const std::string&) {
        refiner_->addFrame(stamp.toSec(), image);
        publishDetections(stamp);
      },
      &error_);
  frames_->holdToSize(intrinsics.imageSize());
  encoders_ = std::make_unique<ros_layer::EncoderInput>(
      nh_,
      [this](const ros::Time& stamp, int left, int right, int resolution) {
        refiner_->addEncoders(stamp.toSec(), left, right, resolution);
      },
      &error_);
  publishStatus(true);

  ros::Rate rate(options_.control_rate_hz);
  const double start_s = ros::Time::now().toSec();
  bool was_in_pass = false;
  try {
    while (ros_layer::ok()) {
      ros::spinOnce();
      if (error_) std::rethrow_exception(error_);
      const double now = ros::Time::now().toSec();
      if (options_.max_duration_s > 0 && now - start_s > options_.max_duration_s) break;
      pollTrim(now);
      const LaneOutput out = refiner_->update(now);
      if (out.commanding) {
        command(out.cmd);
      } else if (was_in_pass && options_.stop_after_pass) {
        command(CarCommand());
      }
      was_in_pass = refiner_->inPass();
      if (out.apply) apply(out.trim);
      publishStatus(false);
      rate.sleep();
    }
  } catch (...) {
    // Never leave the kinematics node with a pass's last command.
    if (was_in_pass) command(CarCommand());
    throw;
  }
  if (was_in_pass) command(CarCommand());
  publishStatus(true);
}

}  // namespace wheels
}  // namespace autocal
