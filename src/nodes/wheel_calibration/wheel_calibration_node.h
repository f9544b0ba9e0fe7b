// wheel_calibration_node — the robot calibrates its wheels by itself (paper 000 §3.3–3.4, §5.1):
// it waits for the camera stage's DONE on calibration/status (or starts at once with
// ~intrinsics_file), turns one wheel at a time until it is aligned with the floor tags, drives
// forward and back while the tags' heading change refines the trim, fits each wheel's deadband
// from its encoder, leaves the tag field, and writes kinematics/<veh>.yaml (wheels::WheelRun does
// the work; this class only wires ROS to it). doc/nodes/wheel_calibration_node.md lists the
// parameters.
//
// Subscribes (relative to the robot's namespace): calibration/status (the camera stage's hand-off),
// camera_node/image/compressed (or image/raw), left_wheel_encoder_node/tick,
// right_wheel_encoder_node/tick. Publishes wheels_driver_node/wheels_cmd, calibration/status
// (phase wheels/<step>), apriltag_detector_node/detections (the tags of each processed frame).
// On success writes the file, sets the running kinematics_node's parameters, publishes DONE whose
// text is "wrote <path>", and returns; every failure is an exception for runNode's failure path.
// A recorded run is recomputed by `rosrun autocal replay` (doc/nodes/replay.md), with no node.
#pragma once

#include <ros/ros.h>

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "autocal/wheels/wheel_run.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/sensor_inputs.h"
#include "autocal_ros/stage_node.h"

namespace autocal {
namespace wheels {

struct WheelCalibrationNodeOptions {
  /// veh, calibration_root, resume, control_rate_hz (>= 20), connect_wait_s, status_rate_hz.
  ros_layer::StageNodeOptions stage;
  /// A camera_info YAML to start with at once; empty: wait for the camera stage's DONE and use the
  /// file it names.
  std::string intrinsics_file;
  /// How long to wait for the camera stage [s]; 0: no limit.
  double camera_stage_wait_s = 0;
  std::string image_transport = "compressed";
  /// Set the running kinematics_node's trim and deadband parameters to the result.
  bool update_kinematics_node = true;
  /// First guess of each wheel's deadband [duty]; negative: the camera stage's minimum moving duty
  /// (its DONE figures), else the kinematics file's offsets.
  double deadband_guess = -1;
  /// The camera stage's two minimum duties within this of each other are one deadband seen twice
  /// (its probe's duty step): both wheels' first guess is their mean (wheels::deadbandGuesses).
  double deadband_guess_resolution = 0.01;
  WheelRunOptions run;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class WheelCalibrationNode {
 public:
  WheelCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs the stage to its end; returns after DONE, throws on failure.
  void run();

 private:
  /// The stage, from the intrinsics (~intrinsics_file, or the camera stage's DONE) and the
  /// deadband guesses.
  std::unique_ptr<Stage> build();
  void publishDetections(double stamp_s);
  CameraIntrinsics readIntrinsics() const;

  ros::NodeHandle nh_, pnh_;
  WheelCalibrationNodeOptions options_;
  KinematicsParams before_;
  std::string kinematics_path_;
  ros_layer::StageNode node_;
  WheelRun* run_ = nullptr;  ///< the stage, once built
  ros::Publisher detections_pub_;
};

}  // namespace wheels
}  // namespace autocal
