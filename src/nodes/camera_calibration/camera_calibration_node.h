// camera_calibration_node — the robot calibrates its camera by itself (paper 000 §3.1–3.2): it
// finds its wheels' minimum moving duty, turns one wheel at a time in steps past the chessboards
// around it, grabs one settled frame per step, and calibrates the views (camera::SweepRun does all
// of it; this class only wires ROS to it). doc/nodes/camera_calibration_node.md lists the
// parameters.
//
// Subscribes (relative to the robot's namespace): camera_node/image/compressed (or image/raw with
// ~image_transport raw), camera_node/camera_info (image size and the fit's starting point only),
// left_wheel_encoder_node/tick, right_wheel_encoder_node/tick. Publishes
// wheels_driver_node/wheels_cmd, calibration/status (phase camera/<step>), and
// ~debug/image/compressed. On success writes <calibration_root>/camera_intrinsic/<veh>.yaml and
// its audit folder, optionally calls camera_node/set_camera_info, publishes DONE whose text is
// "wrote <path>", and returns; every failure is an exception for runNode's failure path. A recorded
// run is recomputed by `rosrun autocal replay` (doc/nodes/replay.md), with no node.
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>

#include <memory>
#include <string>
#include <utility>

#include "autocal/camera/camera_config.h"
#include "autocal/camera/sweep_run.h"
#include "autocal_ros/sensor_inputs.h"
#include "autocal_ros/stage_node.h"

namespace autocal {
namespace camera {

struct CameraCalibrationNodeOptions {
  /// veh, calibration_root, resume, control_rate_hz (>= 10: pulses are 0.1 s), connect_wait_s
  /// (for the camera, camera_info and encoder publishers), status_rate_hz.
  ros_layer::StageNodeOptions stage;
  std::string camera_config;        ///< default: the package's config/camera_calibration.yaml
  std::string board_inner_corners;  ///< e.g. "7x5"; empty: the config's
  double board_square_m = 0;        ///< 0: the config's
  std::string image_transport = "compressed";  ///< "compressed" or "raw"
  /// Wait this long at the start for camera_info [s]; without it the fit starts from OpenCV's
  /// own guess and the sweep from ~camera_hfov_rad.
  double camera_info_wait_s = 3.0;
  bool use_camera_info_guess = true;
  bool set_camera_info = false;  ///< call camera_node/set_camera_info with the result
  SweepRunOptions run;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class CameraCalibrationNode {
 public:
  /// Reads and validates the parameters; throws ConfigError.
  CameraCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs the stage to its end; returns after DONE, throws on failure.
  void run();

 private:
  std::unique_ptr<Stage> build();
  /// Waits up to camera_info_wait_s for camera_info.
  void waitForCameraInfo();
  /// The camera config and run options (camera_info's field of view and guess, when it came).
  std::pair<CameraCalibrationConfig, SweepRunOptions> stageSetup();
  void publishDebug(const cv::Mat& frame);
  void setCameraInfo(const CameraIntrinsics& intrinsics, const std::string& path);

  ros::NodeHandle nh_, pnh_;
  CameraCalibrationNodeOptions options_;
  CameraCalibrationConfig camera_;
  ros_layer::StageNode node_;
  SweepRun* run_ = nullptr;  ///< the stage, once built
  ros::Publisher debug_pub_;
  ros::Subscriber info_sub_;
  bool have_info_ = false;
  sensor_msgs::CameraInfo info_;
};

}  // namespace camera
}  // namespace autocal
