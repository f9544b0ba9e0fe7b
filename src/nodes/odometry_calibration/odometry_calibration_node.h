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

#include <exception>
#include <memory>
#include <string>

#include "autocal/odometry/uah_run.h"
#include "autocal/odometry/umbmark_run.h"
#include "autocal/status_throttle.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace odometry {

struct OdometryCalibrationNodeOptions {
  std::string veh;  ///< default: the last component of the node's namespace
  std::string calibration_root = "/data/config/calibrations";
  /// Resuming a run after a failure: keep this stage's result when the run's last report says
  /// it succeeded and its file still exists (ros_layer::resumeStage).
  bool resume = false;
  /// The nominal robot: wheel radius [m] (both wheels) and wheelbase [m]; the encoder resolution
  /// comes from the encoder messages unless ticks_per_revolution > 0.
  double wheel_radius_m = 0.0318;
  double wheelbase_m = 0.1;
  int ticks_per_revolution = 0;
  double control_rate_hz = 50;
  double connect_wait_s = 5.0;
  double status_rate_hz = 2.0;
  /// "uah" (paper 002 §2) or "umbmark" (Borenstein & Feng).
  std::string method = "uah";
  /// In a calibration run: start only after this stage's DONE on calibration/status (e.g.
  /// "wheels"; empty: at once), and fail on its FAILED or after after_stage_wait_s [wall s, 0:
  /// no limit].
  std::string after_stage;
  double after_stage_wait_s = 0;
  UahRunOptions run;
  /// UMBmark: nominal is set at the start like run.nominal's.
  UmbmarkRunOptions umbmark;
  /// UMBmark's return errors from this YAML file after all squares instead of ~return_error.
  std::string errors_file;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class OdometryCalibrationNode {
 public:
  OdometryCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs the experiments to their end; returns after DONE, throws on failure.
  void run();

 private:
  void start(int ticks_per_revolution);
  void publishStatus(bool force);
  void finish();
  void publishUmbmarkStatus(bool force);
  void finishUmbmark();
  /// Errors-file mode: the file, once it holds every square's error.
  void pollErrorsFile();
  bool umbmark() const { return options_.method == "umbmark"; }
  bool runDone() const {
    return umbmark() ? umbmark_run_ && umbmark_run_->done() : run_ && run_->done();
  }

  ros::NodeHandle nh_, pnh_;
  OdometryCalibrationNodeOptions options_;
  std::unique_ptr<UahRun> run_;
  std::unique_ptr<UmbmarkRun> umbmark_run_;
  ros::Subscriber error_sub_;
  ros::WallTime last_file_poll_;
  ros_layer::StatusPublisher status_;
  ros_layer::WheelsCommander wheels_;
  std::unique_ptr<ros_layer::EncoderInput> encoders_;
  ros::Subscriber range_sub_, length_sub_;
  std::exception_ptr error_;
  bool range_limits_set_ = false;
  StatusThrottle status_throttle_;
};

}  // namespace odometry
}  // namespace autocal
