// odometry_calibration_node — the robot drives paper 002's UAH experiments by itself (§2): it
// pivots on its stopped left wheel, then on its stopped right wheel (whole rounds from the range
// autocorrelation, §2.1), spins in place, and drives straight runs on a free line, then writes
// odometry/<veh>.yaml (odometry::UahRun does the work; this class only wires ROS to it).
// doc/nodes/odometry_calibration_node.md lists the topics and parameters.
//
// With ~method umbmark it drives UMBmark instead (odometry::UmbmarkRun): n squares clockwise, n
// counter-clockwise on its own odometry; after each square it waits for that square's return
// error ε = actual − computed [m] on ~return_error (geometry_msgs/Point, x and y in the square's
// start frame) — measured by a person on a robot, or in the simulator by umbmark_error_helper
// (src/nodes/sim_tools/, a validation tool) — or, with ~errors_file set, it drives all squares
// (pausing ~run_pause_s after each for the person to mark where it stopped) and then waits for that
// YAML file (the `umbmark` command's format). Status phases odometry/umbmark_cw,
// odometry/umbmark_ccw, figures run, leg, awaiting_error, run_start_s, computed_x_m, computed_y_m.
//
// The one measured input: each straight run's true start-to-end length, received on
// ~straight_length (std_msgs/Float64, metres) while the status says the run waits for it — typed
// by a person on a robot (`rostopic pub`), or in the simulator by straight_length_helper
// (src/nodes/sim_tools/: validation tools, not part of the calibration; this node never reads the
// simulator's state).
//
// Subscribes (relative to the robot's namespace): left_wheel_encoder_node/tick,
// right_wheel_encoder_node/tick, front_center_tof_driver_node/range, ~straight_length.
// Publishes wheels_driver_node/wheels_cmd and calibration/status (phase odometry/<experiment>,
// figures round, pulses_per_round, Ed, straight_run, awaiting_length, run_start_s). On success
// writes the file and publishes DONE whose text is "wrote <path>"; every failure is an exception
// for runNode's failure path (wheels stopped, FAILED, nothing written).
#pragma once

#include <ros/ros.h>

#include <string>

#include "autocal/odometry/uah_run.h"
#include "autocal/odometry/umbmark_run.h"
#include "autocal_ros/stage_node.h"

namespace autocal {
namespace odometry {

struct OdometryCalibrationNodeOptions {
  /// veh, calibration_root, resume, control_rate_hz (>= 20), connect_wait_s, status_rate_hz,
  /// after_stage, after_stage_wait_s.
  ros_layer::StageNodeOptions stage;
  /// The nominal robot: wheel radius [m] (both wheels) and wheelbase [m]; the encoder resolution
  /// comes from the encoder messages unless ticks_per_revolution > 0.
  double wheel_radius_m = 0.0318;
  double wheelbase_m = 0.1;
  int ticks_per_revolution = 0;
  /// "uah" (paper 002 §2) or "umbmark" (Borenstein & Feng).
  std::string method = "uah";
  UahRunOptions run;
  /// UMBmark: nominal is set at the start like run.nominal's.
  UmbmarkRunOptions umbmark;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class OdometryCalibrationNode {
 public:
  OdometryCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs the experiments to their end; returns after DONE, throws on failure.
  void run();

 private:
  std::unique_ptr<Stage> build(int ticks_per_revolution);
  void onReturnError(double x_m, double y_m);
  void onStraightLength(double length_m);
  bool umbmark() const { return options_.method == "umbmark"; }

  ros::NodeHandle pnh_;
  OdometryCalibrationNodeOptions options_;
  ros_layer::StageNode node_;
  UahRun* uah_ = nullptr;          ///< the stage, when the method is uah
  UmbmarkRun* umbmark_ = nullptr;  ///< the stage, when the method is umbmark
  ros::Subscriber error_sub_, length_sub_;
};

}  // namespace odometry
}  // namespace autocal
