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

void FrameInput::onCompressed(const sensor_msgs::CompressedImage::ConstPtr& msg) {
  if (*error_ || !wanted_(msg->header.stamp)) return;
  const std::string cut = truncatedImage(msg->data);
  if (!cut.empty()) return drop(cut);
  cv::Mat image;
  if (!msg->data.empty()) image = cv::imdecode(msg->data, cv::IMREAD_GRAYSCALE);
  if (image.empty()) return drop("the JPEG does not decode");
  handle(msg->header.stamp, image, "compressed@" + formatNumber(msg->header.stamp.toSec(), 6));
}

void FrameInput::onRaw(const sensor_msgs::Image::ConstPtr& msg) {
  if (*error_ || !wanted_(msg->header.stamp)) return;
  cv::Mat image;
  try {
    image = cv_bridge::toCvCopy(msg, "mono8")->image;
  } catch (const cv_bridge::Exception& e) {
    return drop(e.what());
  }
  handle(msg->header.stamp, image, "raw@" + formatNumber(msg->header.stamp.toSec(), 6));
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

RecordingFollower::RecordingFollower(ros::NodeHandle nh, const std::string& stage,
                                     const std::string& recorded_status_topic,
                                     CommandHandler on_command, PhaseHandler on_phase,
                                     std::exception_ptr* error)
    : stage_(stage),
      on_command_(std::move(on_command)),
      on_phase_(std::move(on_phase)),
      error_(error) {
  // Every command of the recording counts: a drive's start and stop cut the motions.
  cmd_sub_ =
      nh.subscribe("wheels_driver_node/wheels_cmd", 200, &RecordingFollower::onCommand, this);
  status_sub_ = nh.subscribe(recorded_status_topic, 50, &RecordingFollower::onStatus, this);
  status_topic_ = status_sub_.getTopic();
}

template <typename F>
void RecordingFollower::guarded(F&& f) {
  if (*error_) return;
  try {
    f();
  } catch (...) {
    *error_ = std::current_exception();
  }
}

void RecordingFollower::onCommand(const dtmsg::WheelsCmdStamped::ConstPtr& msg) {
  guarded([&] {
    ++messages_;
    noteMessage();
    const ros::Time stamp = msg->header.stamp.isZero() ? ros::Time::now() : msg->header.stamp;
    on_command_(stamp, WheelDuties{msg->vel_left, msg->vel_right});
  });
}

void RecordingFollower::onStatus(const autocal::CalibrationStatus::ConstPtr& msg) {
  guarded([&] {
    ++messages_;
    noteMessage();
    if (msg->phase.rfind(stage_ + "/", 0) != 0) return;
    if (msg->phase != stage_ + "/wait") started_ = true;
    if (msg->progress >= 0 && msg->progress <= 1)
      progress_ = std::max(progress_, static_cast<double>(msg->progress));
    const ros::Time stamp = msg->header.stamp.isZero() ? ros::Time::now() : msg->header.stamp;
    on_phase_(stamp, msg->phase);
    if (msg->state == autocal::CalibrationStatus::STATE_DONE ||
        msg->state == autocal::CalibrationStatus::STATE_FAILED) {
      ended_ = true;
      failed_ = msg->state == autocal::CalibrationStatus::STATE_FAILED;
      failure_ = msg->failure_reason;
    }
  });
}

bool RecordingFollower::recordingEnded(double wait_s) {
  const ros::WallTime now = ros::WallTime::now();
  if (clock_start_wall_.isZero()) {
    if (ros::Time::now().isZero()) return false;  // rosbag play has not started
    clock_start_wall_ = now;
  }
  const ros::WallTime since = std::max(last_message_wall_, clock_start_wall_);
  return (now - since).toSec() > wait_s;
}

bool RecordingFollower::followToEnd(double rate_hz, double end_wait_s,
                                    const std::exception_ptr& error,
                                    const std::function<void()>& each_step,
                                    const std::function<std::string()>& describe) {
  // "the wheel stage": the stage's name as a person says it.
  const std::string noun = stage_ == "wheels" ? "wheel" : stage_;
  ros::WallRate rate(rate_hz);
  while (ok() && !ended_) {
    ros::spinOnce();
    if (error) std::rethrow_exception(error);
    each_step();
    if (recordingEnded(end_wait_s)) {
      throw InputError("the recording ended before its " + noun + " stage did (" + describe() +
                       (started_ ? "; the stage's end is not in it)"
                                 : "; no status of the " + noun + " stage on " + status_topic_ +
                                       ": was calibration/status recorded?)"));
    }
    rate.sleep();
  }
  if (!ok()) return false;
  if (failed_)
    ROS_WARN("%s: the recorded %s stage FAILED (%s); recomputing what it did",
             ros::this_node::getName().c_str(), noun.c_str(), failure_.c_str());
  return true;
}

}  // namespace ros_layer
}  // namespace autocal
