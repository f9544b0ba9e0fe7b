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

#include "autocal/sensors.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace ros_layer {

/// A camera frame as 8-bit grey: the JPEG decoded (an empty image when it does not, and `why` says
/// why), or the raw image converted.
cv::Mat decodeFrame(const sensor_msgs::CompressedImage& msg, std::string& why);
cv::Mat decodeFrame(const sensor_msgs::Image& msg, std::string& why);
/// The frame's name in a stage's records: "compressed@<stamp>", "raw@<stamp>".
std::string frameSource(const std::string& transport, const ros::Time& stamp);

class FrameInput {
 public:
  /// Called for every frame's stamp; true when the frame is to be decoded and handled.
  using Wanted = std::function<bool(const ros::Time& stamp)>;
  using Handler =
      std::function<void(const ros::Time& stamp, const cv::Mat& gray, const std::string& source)>;

  /// Subscribes with `this`: not copyable or movable (hold it in a unique_ptr).
  /// `transport`: "compressed" or "raw". `error` receives a handler's exception.
  /// `queue_size`: frames waiting while one is handled.
  FrameInput(ros::NodeHandle nh, const std::string& transport, const std::string& node_name,
             Wanted wanted, Handler handler, std::exception_ptr* error, int queue_size = 2);
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

  /// Called on every tick message with its wheel (0 left, 1 right), stamp, count and resolution.
  using WheelHandler = std::function<void(int side, const ros::Time& stamp, std::int32_t ticks,
                                          int ticks_per_revolution)>;

  /// Subscribes with `this`: not copyable or movable (hold it in a unique_ptr). `queue_size`
  /// readings per wheel wait while the node is busy.
  EncoderInput(ros::NodeHandle nh, Handler handler, std::exception_ptr* error,
               WheelHandler on_wheel = {}, uint32_t queue_size = 50);
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
  WheelHandler on_wheel_;
  std::exception_ptr* error_ = nullptr;
  bool have_left_ = false, have_right_ = false;
  int left_ = 0, right_ = 0, resolution_ = 0;
};

}  // namespace ros_layer
}  // namespace autocal
