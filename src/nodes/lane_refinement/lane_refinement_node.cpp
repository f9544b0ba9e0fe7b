#include "lane_refinement_node.h"

#include <std_srvs/Empty.h>

#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal_ros/msg_conversion.h"

namespace autocal {
namespace wheels {

LaneRefinementNode::LaneRefinementNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readLaneRefinementNodeOptions(nh, pnh)),
      throttle_(options_.status_rate_hz) {
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
  throttle_.due("lane/applied", ros::Time::now().toSec(), true);
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
  const auto& passes = refiner_->passes();
  // At once on a new phase or pass (and logged), otherwise at ~status_rate_hz.
  if (!throttle_.due(phase + " " + std::to_string(passes.size()), ros::Time::now().toSec(), force))
    return;
  if (throttle_.keyChanged())
    ROS_INFO("lane_refinement_node: %s: %s", phase.c_str(), refiner_->describe().c_str());
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
  const CameraIntrinsics intrinsics = ros_layer::readIntrinsicsFile(
      options_.intrinsics_file, "~intrinsics_file; the refinement needs the calibrated camera");
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
