#include "camera_view_node.h"

#include <sensor_msgs/Image.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
#include "autocal/report/camera_view.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace report {

void CameraViewNodeOptions::validate() const {
  ros_layer::checkParam(std::isfinite(max_rate_hz) && max_rate_hz > 0, "max_rate_hz",
                        "must be > 0 [Hz]");
  ros_layer::checkParam(std::isfinite(debug_timeout_s) && debug_timeout_s > 0, "debug_timeout_s",
                        "must be > 0 [s]");
  ros_layer::checkParam(std::isfinite(overlay_hold_s) && overlay_hold_s >= 0, "overlay_hold_s",
                        "must be >= 0 [s]");
}

CameraViewNode::CameraViewNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
  const ros_layer::ParamReader p(pnh_, "camera_view_node");
  p.get("max_rate_hz", options_.max_rate_hz);
  p.get("debug_timeout_s", options_.debug_timeout_s);
  p.get("overlay_hold_s", options_.overlay_hold_s);
  options_.validate();
  // Subscribe to the inputs only while somebody looks.
  const ros::SubscriberStatusCallback connection = [this](const ros::SingleSubscriberPublisher&) {
    onConnection();
  };
  image_pub_ = nh_.advertise<sensor_msgs::Image>("camera_view/image", 1, connection, connection);
}

void CameraViewNode::onConnection() {
  const bool wanted = image_pub_.getNumSubscribers() > 0;
  if (wanted && !frame_sub_) {
    debug_sub_ = nh_.subscribe("camera_calibration_node/debug/image/compressed", 1,
                               &CameraViewNode::onDebugImage, this);
    frame_sub_ = nh_.subscribe("camera_node/image/compressed", 1, &CameraViewNode::onFrame, this);
    detections_sub_ =
        nh_.subscribe("apriltag_detector_node/detections", 5, &CameraViewNode::onDetections, this);
  } else if (!wanted && frame_sub_) {
    debug_sub_.shutdown();
    frame_sub_.shutdown();
    detections_sub_.shutdown();
    debug_sub_ = frame_sub_ = detections_sub_ = ros::Subscriber();
  }
}

bool CameraViewNode::due() {
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_published_).toSec() < 1.0 / options_.max_rate_hz) return false;
  last_published_ = now;
  return true;
}

void CameraViewNode::onDebugImage(const sensor_msgs::CompressedImage::ConstPtr& msg) {
  last_debug_ = ros::WallTime::now();
  if (due()) publish(*msg, false);
}

void CameraViewNode::onFrame(const sensor_msgs::CompressedImage::ConstPtr& msg) {
  frames_.push_back(msg);
  if (frames_.size() > kBufferedFrames) frames_.pop_front();
  // The camera stage's own image, with its detections, comes first while it comes.
  if ((ros::WallTime::now() - last_debug_).toSec() < options_.debug_timeout_s) return;
  // Its detections came first (the wheel stage is quick).
  if (msg->header.stamp == detections_stamp_) {
    showWithDetections(*msg);
    return;
  }
  // A frame with detections stays up a while: the wheel stage looks at frames in bursts.
  if ((ros::WallTime::now() - last_overlay_).toSec() < options_.overlay_hold_s) return;
  if (due()) publish(*msg, false);
}

void CameraViewNode::onDetections(const dtmsg::AprilTagDetectionArray::ConstPtr& msg) {
  std::vector<markers::TagDetection> detections;
  try {
    for (const dtmsg::AprilTagDetection& d : msg->detections)
      detections.push_back(ros_layer::fromTagDetectionMsg(d));
  } catch (const Error& e) {
    ROS_WARN_THROTTLE(5.0, "camera_view_node: dropped detections: %s", e.what());
    return;
  }
  detections_stamp_ = msg->header.stamp;
  detections_ = std::move(detections);
  if ((ros::WallTime::now() - last_debug_).toSec() < options_.debug_timeout_s) return;
  // Its frame came first (the usual order: the stage answers a frame it received).
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it) {
    if ((*it)->header.stamp == detections_stamp_) {
      showWithDetections(**it);
      return;
    }
  }
}

void CameraViewNode::showWithDetections(const sensor_msgs::CompressedImage& frame) {
  if (detections_.empty() || !due()) return;
  publish(frame, true);
  last_overlay_ = ros::WallTime::now();
}

void CameraViewNode::publish(const sensor_msgs::CompressedImage& msg, bool draw_detections) {
  cv::Mat image = cv::imdecode(msg.data, cv::IMREAD_COLOR);
  if (image.empty()) {
    ROS_WARN_THROTTLE(5.0, "camera_view_node: dropped an image that does not decode");
    return;
  }
  if (draw_detections) drawTagDetections(image, detections_);
  sensor_msgs::Image out;
  out.header = msg.header;
  out.height = static_cast<uint32_t>(image.rows);
  out.width = static_cast<uint32_t>(image.cols);
  out.encoding = "bgr8";
  out.step = static_cast<uint32_t>(image.step);
  out.data.assign(image.datastart, image.dataend);
  image_pub_.publish(out);
}

}  // namespace report
}  // namespace autocal
