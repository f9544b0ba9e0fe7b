#include "autocal_ros/sensor_inputs.h"

#include <cv_bridge/cv_bridge.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/node_runtime.h"

namespace autocal {
namespace ros_layer {

FrameInput::FrameInput(ros::NodeHandle nh, const std::string& transport,
                       const std::string& node_name, Wanted wanted, Handler handler,
                       std::exception_ptr* error, int queue_size)
    : node_name_(node_name),
      wanted_(std::move(wanted)),
      handler_(std::move(handler)),
      error_(error) {
  if (transport == "compressed") {
    sub_ =
        nh.subscribe("camera_node/image/compressed", queue_size, &FrameInput::onCompressed, this);
  } else {
    sub_ = nh.subscribe("camera_node/image/raw", queue_size, &FrameInput::onRaw, this);
  }
}

void FrameInput::drop(const std::string& why) {
  ++dropped_;
  ROS_WARN_THROTTLE(5, "%s: dropped a frame: %s (%d so far)", node_name_.c_str(), why.c_str(),
                    dropped_);
}

cv::Mat decodeFrame(const sensor_msgs::CompressedImage& msg, std::string& why) {
  why = truncatedImage(msg.data);
  if (!why.empty()) return {};
  cv::Mat image;
  if (!msg.data.empty()) image = cv::imdecode(msg.data, cv::IMREAD_GRAYSCALE);
  if (image.empty()) why = "the JPEG does not decode";
  return image;
}

cv::Mat decodeFrame(const sensor_msgs::Image& msg, std::string& why) {
  try {
    return cv_bridge::toCvCopy(msg, "mono8")->image;
  } catch (const cv_bridge::Exception& e) {
    why = e.what();
    return {};
  }
}

std::string frameSource(const std::string& transport, const ros::Time& stamp) {
  return transport + "@" + formatNumber(stamp.toSec(), 6);
}

void FrameInput::onCompressed(const sensor_msgs::CompressedImage::ConstPtr& msg) {
  if (*error_ || !wanted_(msg->header.stamp)) return;
  std::string why;
  const cv::Mat image = decodeFrame(*msg, why);
  if (image.empty()) return drop(why);
  handle(msg->header.stamp, image, frameSource("compressed", msg->header.stamp));
}

void FrameInput::onRaw(const sensor_msgs::Image::ConstPtr& msg) {
  if (*error_ || !wanted_(msg->header.stamp)) return;
  std::string why;
  const cv::Mat image = decodeFrame(*msg, why);
  if (image.empty()) return drop(why);
  handle(msg->header.stamp, image, frameSource("raw", msg->header.stamp));
}

void FrameInput::handle(const ros::Time& stamp, const cv::Mat& image, const std::string& source) {
  // The size camera_info gives, else the first frame's: a frame of another size is dropped (and
  // never becomes the size the others are held to).
  if (size_.area() > 0 && image.size() != size_) {
    return drop("it is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                ", the camera's frames are " + std::to_string(size_.width) + "x" +
                std::to_string(size_.height));
  }
  if (size_.area() == 0) size_ = image.size();
  try {
    handler_(stamp, image, source);
  } catch (...) {
    *error_ = std::current_exception();
  }
}

EncoderInput::EncoderInput(ros::NodeHandle nh, Handler handler, std::exception_ptr* error,
                           WheelHandler on_wheel, uint32_t queue_size)
    : handler_(std::move(handler)), on_wheel_(std::move(on_wheel)), error_(error) {
  left_sub_ = nh.subscribe<dtmsg::WheelEncoderStamped>(
      "left_wheel_encoder_node/tick", queue_size,
      [this](const dtmsg::WheelEncoderStamped::ConstPtr& m) { on(m, true); });
  right_sub_ = nh.subscribe<dtmsg::WheelEncoderStamped>(
      "right_wheel_encoder_node/tick", queue_size,
      [this](const dtmsg::WheelEncoderStamped::ConstPtr& m) { on(m, false); });
}

void EncoderInput::on(const dtmsg::WheelEncoderStamped::ConstPtr& msg, bool left) {
  if (*error_) return;
  try {
    const EncoderReading r = fromEncoderMsg(*msg);
    (left ? left_ : right_) = r.ticks;
    (left ? have_left_ : have_right_) = true;
    resolution_ = r.ticks_per_revolution;
    if (on_wheel_) on_wheel_(left ? 0 : 1, msg->header.stamp, r.ticks, resolution_);
    if (valid()) handler_(msg->header.stamp, left_, right_, resolution_);
  } catch (...) {
    *error_ = std::current_exception();
  }
}

}  // namespace ros_layer
}  // namespace autocal
