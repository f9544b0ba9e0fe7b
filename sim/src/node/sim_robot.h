// One simulated Duckiebot of sim_node (the node runs one, or a fleet on one clock): its physics
// (Simulation), its camera (Renderer), its noise sources, and the topics a Duckiebot publishes in
// its namespace — camera (JPEG and raw, camera_info with the NOMINAL model), wheel encoders, range
// — plus its ground truth, and for RViz its area's markers, its true path and its start as the
// odom frame. It drives the wheels from wheels_cmd, with the watchdog and the lockstep state.
#pragma once

#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <functional>
#include <memory>
#include <random>
#include <string>

#include "autocal/sensors.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "autocal/sim/transport.h"
#include "autocal_ros/msgs.h"

namespace tf2_ros {
class TransformBroadcaster;
class StaticTransformBroadcaster;
}  // namespace tf2_ros

namespace autocal {
namespace sim {

struct SimNodeOptions;

/// An output due at multiples of its period (in simulated time).
struct Schedule {
  double period_s = 1;
  double next_s = 0;
  /// True (and the next time set) when the step ending at `t_s` reaches it.
  bool due(double t_s, double dt_s);
};

class SimRobot {
 public:
  /// `nh`: the robot's namespace. `area_frame`: the frame of its calibration area (the world frame
  /// for a single robot; "<veh>/area" in a fleet, placed by `area_offset`). `seed`: its own.
  SimRobot(ros::NodeHandle nh, const SimNodeOptions& options, const std::string& vehicle,
           const RobotConfig& robot, const WorldConfig& world, int seed,
           const std::string& area_frame, const Pose2& area_offset,
           tf2_ros::TransformBroadcaster& tf, tf2_ros::StaticTransformBroadcaster& static_tf);
  ~SimRobot();

  /// One physics step; the wheels stop when no wheels_cmd came for wheels_cmd_timeout_s.
  void step();
  /// Publishes what is due after the step (encoders, range, truth) and, when a camera frame is
  /// due, its camera_info; true when the frame is to be rendered (somebody subscribes to an image
  /// topic): then renderFrame() and publishFrame() follow.
  bool publishDue();
  /// Renders (and JPEG-encodes) the due frame. Touches only this robot's renderer, noise source
  /// and pending messages, and reads its simulation: the robots of a fleet render theirs at once,
  /// each on a thread of its own, while nothing steps.
  void renderFrame();
  /// Publishes the frame renderFrame() made.
  void publishFrame();
  /// Latched markers of its area and robot; static TFs (the area, the odom frame).
  void publishVizStatic();
  void stop() { sim_->setDuty(0.0, 0.0); }

  /// Lockstep: this robot's controller has commanded and time ran more than lockstep_s past its
  /// last command (not released).
  bool behind() const;
  /// Releases the lockstep until the next command (the controller is silent or ended).
  void release() { lockstep_released_ = true; }
  double lastCommandS() const { return last_cmd_s_; }
  bool hasController() const { return wheels_cmd_sub_.getNumPublishers() > 0; }
  bool watchdogStopped() const { return watchdog_stopped_; }
  const std::string& vehicle() const { return vehicle_; }
  std::string wheelsCmdTopic() const { return wheels_cmd_sub_.getTopic(); }
  const Simulation& simulation() const { return *sim_; }

 private:
  void onWheelsCmd(const dtmsg::WheelsCmdStamped::ConstPtr& msg);
  void publishEncoders();
  void publishRange();
  /// Publishes camera_info for a frame captured at capture_s; true when it is to be rendered.
  bool beginFrame(double capture_s);
  void publishGroundTruth();
  /// Publishes the messages whose transport delay (RobotConfig::transport) has passed.
  void releaseDue();
  void publishTruePath();

  ros::NodeHandle nh_;
  const SimNodeOptions& options_;
  std::string vehicle_;
  RobotConfig robot_;
  WorldConfig world_;
  std::string area_frame_;
  Pose2 area_offset_;
  tf2_ros::TransformBroadcaster& tf_;
  tf2_ros::StaticTransformBroadcaster& static_tf_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<Renderer> renderer_;
  std::mt19937_64 camera_rng_, range_rng_;
  Schedule encoders_, range_, camera_, truth_;
  ros::Subscriber wheels_cmd_sub_;
  ros::Publisher left_tick_pub_, right_tick_pub_, range_pub_, image_pub_, compressed_pub_,
      camera_info_pub_, ground_truth_pub_, world_markers_pub_, true_path_pub_;
  nav_msgs::Path true_path_;
  ros::WallTime last_path_;
  /// The frame due: its capture time, which topics want it, and its messages once rendered.
  double frame_capture_s_ = 0;
  bool frame_compressed_ = false, frame_raw_ = false;
  sensor_msgs::CameraInfo frame_info_;
  sensor_msgs::CompressedImage frame_jpeg_;
  sensor_msgs::Image frame_image_;
  /// The robot's links (RobotConfig::transport): messages wait here for their release time.
  using Send = std::function<void()>;
  DelayQueue<Send> camera_link_, left_encoder_link_, right_encoder_link_, range_link_;
  DelayQueue<WheelDuties> wheels_cmd_link_;
  double last_cmd_s_ = -1e9;
  bool watchdog_stopped_ = true;
  bool have_cmd_ = false, lockstep_released_ = false;
  std::string camera_frame_, range_frame_, ground_truth_frame_, odom_frame_;
};

}  // namespace sim
}  // namespace autocal
