// The robot's camera and wheel encoders as every calibration node subscribes to them: frames
// decoded only when the stage wants them (camera_node/image/compressed, decoded with cv::imdecode
// since Debian has no compressed image_transport plugin, or camera_node/image/raw), held to one
// size, a bad frame dropped with a throttled warning; the two encoder ticks combined into one
// reading. A handler's exception is kept for the node's loop to rethrow (one failure path).
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <exception>
#include <functional>
#include <opencv2/core.hpp>
#include <string>

#include "autocal_ros/msgs.h"

namespace autocal {
namespace ros_layer {

class FrameInput {
 public:
  /// Called for every frame's stamp; true when the frame is to be decoded and handled.
  using Wanted = std::function<bool(const ros::Time& stamp)>;
  using Handler =
      std::function<void(const ros::Time& stamp, const cv::Mat& gray, const std::string& source)>;

  /// Subscribes with `this`: not copyable or movable (hold it in a unique_ptr).
  /// `transport`: "compressed" or "raw". `error` receives a handler's exception.
  FrameInput(ros::NodeHandle nh, const std::string& transport, const std::string& node_name,
             Wanted wanted, Handler handler, std::exception_ptr* error);
  /// Frames of another size are dropped (default: the first frame's size).
  FrameInput(const FrameInput&) = delete;
  FrameInput& operator=(const FrameInput&) = delete;
  void holdToSize(const cv::Size& size) { size_ = size; }
  int dropped() const { return dropped_; }
  uint32_t publishers() const { return sub_.getNumPublishers(); }

 private:
  void onCompressed(const sensor_msgs::CompressedImage::ConstPtr& msg);
  void onRaw(const sensor_msgs::Image::ConstPtr& msg);
  void handle(const ros::Time& stamp, const cv::Mat& image, const std::string& source);
  void drop(const std::string& why);

  ros::Subscriber sub_;
  std::string node_name_;
  Wanted wanted_;
  Handler handler_;
  std::exception_ptr* error_ = nullptr;
  cv::Size size_;
  int dropped_ = 0;
};

class EncoderInput {
 public:
  /// Called on every tick message once both wheels have reported: the stamp of the message, both
  /// cumulative counts and the resolution [ticks/rev].
  using Handler =
      std::function<void(const ros::Time& stamp, int left, int right, int ticks_per_revolution)>;

  /// Subscribes with `this`: not copyable or movable (hold it in a unique_ptr).
  EncoderInput(ros::NodeHandle nh, Handler handler, std::exception_ptr* error);
  EncoderInput(const EncoderInput&) = delete;
  EncoderInput& operator=(const EncoderInput&) = delete;
  bool connected() const {
    return left_sub_.getNumPublishers() > 0 && right_sub_.getNumPublishers() > 0;
  }
  /// The latest reading (valid once both wheels reported).
  bool valid() const { return have_left_ && have_right_; }
  int left() const { return left_; }
  int right() const { return right_; }
  int resolution() const { return resolution_; }

 private:
  void on(const dtmsg::WheelEncoderStamped::ConstPtr& msg, bool left);

  ros::Subscriber left_sub_, right_sub_;
  Handler handler_;
  std::exception_ptr* error_ = nullptr;
  bool have_left_ = false, have_right_ = false;
  int left_ = 0, right_ = 0, resolution_ = 0;
};

}  // namespace ros_layer
}  // namespace autocal
