// lane_refinement_node — refines the wheel calibration while the robot drives its lane (paper 000
// §5.2; wheels::LaneRefiner does the work, this class only wires ROS to it). Idle it commands
// nothing (the lane follower drives); seeing the segment's first tag id near straight ahead starts
// a pass, during which it publishes kinematics_node/car_cmd; a new trim, once stable over passes
// and different enough from the one in use, is set as the kinematics node's `trim` parameter and
// saved through its ~save_calibration service. doc/nodes/lane_refinement_node.md lists the
// parameters.
//
// Subscribes (relative to the robot's namespace): camera_node/image/compressed (or image/raw),
// left_wheel_encoder_node/tick, right_wheel_encoder_node/tick. Publishes kinematics_node/car_cmd
// (during passes only), calibration/status (phase lane/idle|pass|applied) and
// apriltag_detector_node/detections (the tags of each processed frame, while subscribed). Calls
// kinematics_node/save_calibration. Runs until shutdown (or ~max_duration_s); every failure is an
// exception for runNode's failure path.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <memory>
#include <string>

#include "autocal/status_throttle.h"
#include "autocal/wheels/lane_refiner.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace wheels {

struct LaneRefinementNodeOptions {
  std::string veh;  ///< default: the last component of the node's namespace
  std::string calibration_root = "/data/config/calibrations";
  /// The calibrated camera; empty: <calibration_root>/camera_intrinsic/<veh>.yaml.
  std::string intrinsics_file;
  std::string image_transport = "compressed";
  double control_rate_hz = 30;
  double status_rate_hz = 1.0;
  /// Publish one zero car_cmd when a pass ends or aborts (a robot without a lane follower stops).
  bool stop_after_pass = true;
  /// Call kinematics_node/save_calibration after setting a new trim.
  bool save_calibration = true;
  double service_wait_s = 2.0;  ///< [wall s]
  /// Re-read kinematics_node/trim between passes this often [s] (it may be changed by hand).
  double trim_poll_s = 1.0;
  /// Stop (exit 0) after this long [s]; 0: run until shutdown.
  double max_duration_s = 0;
  LaneRefinerOptions refiner;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// The node's private parameters that are set (lane_refinement_options.cpp), validated; ConfigError
/// names the first bad key.
LaneRefinementNodeOptions readLaneRefinementNodeOptions(const ros::NodeHandle& nh,
                                                        const ros::NodeHandle& pnh);

class LaneRefinementNode {
 public:
  LaneRefinementNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs until shutdown or ~max_duration_s; throws on failure.
  void run();

 private:
  void command(const CarCommand& cmd);
  void apply(double trim);
  void pollTrim(double now_s);
  void publishStatus(bool force);
  void publishDetections(const ros::Time& stamp);

  ros::NodeHandle nh_, pnh_;
  LaneRefinementNodeOptions options_;
  std::unique_ptr<LaneRefiner> refiner_;
  ros_layer::StatusPublisher status_;
  ros::Publisher car_cmd_pub_, detections_pub_;
  std::unique_ptr<ros_layer::FrameInput> frames_;
  std::unique_ptr<ros_layer::EncoderInput> encoders_;
  std::exception_ptr error_;
  std::string kinematics_path_;
  StatusThrottle throttle_;
  double last_trim_poll_s_ = -1e9;
  double trim_before_ = 0;
};

}  // namespace wheels
}  // namespace autocal
