#include "focus_node.h"

#include <cv_bridge/cv_bridge.h>
#include <ros/callback_queue.h>
#include <ros/package.h>
#include <sensor_msgs/Image.h>

#include <cmath>

#include "autocal/camera/camera_config.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace camera {

void FocusNodeOptions::validate() const {
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(board_square_m >= 0, "board_square_m", "must be > 0 (0: the config's)");
  ros_layer::checkParam(std::isfinite(status_rate_hz) && status_rate_hz > 0, "status_rate_hz",
                        "must be > 0 [Hz]");
  ros_layer::checkParam(std::isfinite(max_duration_s) && max_duration_s >= 0, "max_duration_s",
                        "must be >= 0 [s]");
}

namespace {

FocusNodeOptions readOptions(const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "focus_node");
  FocusNodeOptions o;
  o.camera_config = ros::package::getPath("autocal") + "/config/camera_calibration.yaml";
  p.get("camera_config", o.camera_config);
  p.get("board_inner_corners", o.board_inner_corners);
  p.get("board_square_m", o.board_square_m);
  p.get("image_transport", o.image_transport);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("max_duration_s", o.max_duration_s);
  o.validate();
  return o;
}

}  // namespace

FocusNode::FocusNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), options_(readOptions(pnh)), throttle_(options_.status_rate_hz) {
  const CameraCalibrationConfig config = loadStageCameraConfig(
      options_.camera_config, options_.board_inner_corners, options_.board_square_m);
  FocusMeterOptions m;
  m.board = config.board;
  m.detector = config.detector;
  meter_ = std::make_unique<FocusMeter>(m);
  status_ = ros_layer::StatusPublisher(nh_, "focus/status");
  image_pub_ = nh_.advertise<sensor_msgs::Image>("camera_view/image", 1);
  ROS_INFO(
      "focus_node: measuring the %s board in %s frames; turn the focus ring slowly through "
      "the sharpest point and back to it",
      m.board.describe().c_str(), options_.image_transport.c_str());
  status_.running("focus/measure", -1, "waiting for frames", {{"board", 0.0}});
}

void FocusNode::onFrame(const ros::Time& stamp, const cv::Mat& gray) {
  const FocusReading r = meter_->add(stamp.toSec(), gray);
  if (image_pub_.getNumSubscribers() > 0) {
    cv_bridge::CvImage out;
    out.header.stamp = stamp;
    out.encoding = "bgr8";
    out.image = drawFocus(gray, r);
    image_pub_.publish(out.toImageMsg());
  }
  // At once when the board comes or goes or the reading reaches the best, else at the rate.
  const std::string key = std::string(r.board ? "board" : "none") + (r.at_best ? " best" : "");
  if (!throttle_.due(key, ros::WallTime::now().toSec())) return;
  ROS_INFO("focus_node: %s", r.describe().c_str());
  status_.running("focus/measure", -1, r.describe(),
                  {{"sharpness", r.sharpness},
                   {"best", r.best},
                   {"edge_width_px", r.edge_width_px},
                   {"board", r.board ? 1.0 : 0.0}});
}

void FocusNode::run() {
  frames_ = std::make_unique<ros_layer::FrameInput>(
      nh_, options_.image_transport, "focus_node", [](const ros::Time&) { return true; },
      [this](const ros::Time& stamp, const cv::Mat& gray, const std::string&) {
        onFrame(stamp, gray);
      },
      &error_);
  const ros::WallTime start = ros::WallTime::now();
  while (ros_layer::ok()) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
    if (error_) std::rethrow_exception(error_);
    if (options_.max_duration_s > 0 &&
        (ros::WallTime::now() - start).toSec() > options_.max_duration_s)
      break;
  }
}

}  // namespace camera
}  // namespace autocal
