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

class FrameInput {
 public:
  /// Called for every frame's stamp; true when the frame is to be decoded and handled.
  using Wanted = std::function<bool(const ros::Time& stamp)>;
  using Handler =
      std::function<void(const ros::Time& stamp, const cv::Mat& gray, const std::string& source)>;

  /// Subscribes with `this`: not copyable or movable (hold it in a unique_ptr).
  /// `transport`: "compressed" or "raw". `error` receives a handler's exception.
  /// `queue_size`: frames waiting while one is handled (a replay keeps more: none may be lost).
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
  /// readings per wheel wait while the node is busy (a replay, fed faster than real time, must
  /// lose none: a lost reading at a drive's end moves the rate the deadband fit sees).
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

/// A passive stage's view of a recording played with `rosbag play --clock` (replay.launch): the
/// commands the robot was given (wheels_driver_node/wheels_cmd, which the passive node only reads)
/// and the recorded run's status of one stage, on `recorded_status_topic` (where replay.launch
/// remaps the bag's calibration/status, so that it does not mix with the replay's own).
class RecordingFollower {
 public:
  using CommandHandler = std::function<void(const ros::Time& stamp, const WheelDuties& duties)>;
  /// Every recorded status of the stage: its stamp and phase ("<stage>/<step>").
  using PhaseHandler = std::function<void(const ros::Time& stamp, const std::string& phase)>;
  /// Subscribes with `this`: not copyable or movable. `error` receives a handler's exception.
  RecordingFollower(ros::NodeHandle nh, const std::string& stage,
                    const std::string& recorded_status_topic, CommandHandler on_command,
                    PhaseHandler on_phase, std::exception_ptr* error);
  RecordingFollower(const RecordingFollower&) = delete;
  RecordingFollower& operator=(const RecordingFollower&) = delete;

  /// The recorded stage has begun: a phase of it other than "<stage>/wait" was seen.
  bool stageStarted() const { return started_; }
  /// The recorded stage published DONE or FAILED (failed(): FAILED, with its reason).
  bool stageEnded() const { return ended_; }
  bool stageFailed() const { return failed_; }
  const std::string& failure() const { return failure_; }
  /// The recorded stage's progress so far, 0-1 (the largest its statuses gave): how far the
  /// recording has played through the stage.
  double progress() const { return progress_; }
  /// Messages of the recording seen so far (commands and statuses).
  int messages() const { return messages_; }
  /// Another message of the recording arrived (the node's frames and encoders; commands and
  /// statuses are noted here).
  void noteMessage() { last_message_wall_ = ros::WallTime::now(); }
  /// True when no message of the recording came for `wait_s` of wall time since the recording's
  /// clock started (rosbag play --keep-alive goes on publishing its clock past the end): the
  /// recording ended, or holds none of the stage's topics. Call it from the node's loop.
  bool recordingEnded(double wait_s);
  const std::string& statusTopic() const { return status_topic_; }

  /// A passive node's loop: handles the callbacks at `rate_hz` [wall] until the recorded stage
  /// ended, rethrowing what a callback kept in `error` and calling `each_step` after each batch
  /// (the node's status, its own checks). Throws InputError when the recording ends first ("the
  /// recording ended before its <stage> stage did (<describe()>; ...)"). Returns false when
  /// interrupted; warns when the recorded stage FAILED (the replay recomputes what it did).
  bool followToEnd(double rate_hz, double end_wait_s, const std::exception_ptr& error,
                   const std::function<void()>& each_step,
                   const std::function<std::string()>& describe);

 private:
  void onCommand(const dtmsg::WheelsCmdStamped::ConstPtr& msg);
  void onStatus(const autocal::CalibrationStatus::ConstPtr& msg);
  template <typename F>
  void guarded(F&& f);

  ros::Subscriber cmd_sub_, status_sub_;
  std::string stage_, status_topic_;
  CommandHandler on_command_;
  PhaseHandler on_phase_;
  std::exception_ptr* error_ = nullptr;
  bool started_ = false, ended_ = false, failed_ = false;
  std::string failure_;
  double progress_ = 0;
  int messages_ = 0;
  ros::WallTime clock_start_wall_, last_message_wall_;
};

}  // namespace ros_layer
}  // namespace autocal
