// validate_straight — Duckietown's acceptance test of the wheel calibration, automated: drive
// ~distance_m (2 m) straight through the kinematics node at each of ~speeds_mps and report the
// lateral drift from the line the robot started on (Duckietown accepts 10 cm).
//
// ~source "ground_truth" (the simulator): the drift and the distance come from sim/ground_truth
// (nav_msgs/Odometry), the simulator's truth — a validation tool, not part of the calibration.
// ~source "user" (a robot): the distance comes from the wheel encoders (~radius_m), and after each
// drive the user measures the offset from the tape and types it in centimetres.
//
// Publishes kinematics_node/car_cmd (duckietown_msgs/Twist2DStamped) and calibration/status
// (phase validate/<speed>, DONE with drift_cm_<i> figures); between speeds it drives back as far
// (~drive_back). Exit 0 when every drift is within ~max_drift_m, 1 (calibration failed) when one is
// not and ~fail_above_max_drift is true; doc/nodes/validate_straight.md.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "autocal/pose2d.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace wheels {

struct ValidateStraightOptions {
  std::string veh;                       ///< default: the last component of the namespace
  std::vector<double> speeds_mps{0.25};  ///< each > 0 and <= 1 [m/s]
  double distance_m = 2.0;               ///< Duckietown: 2 m
  std::string source = "ground_truth";   ///< "ground_truth" (simulator) or "user" (robot)
  double max_drift_m = 0.10;             ///< Duckietown's acceptance [m]
  bool fail_above_max_drift = true;      ///< exit 1 when a drift exceeds max_drift_m
  bool drive_back = true;                ///< return to the start between speeds
  double radius_m = 0.0318;              ///< wheel radius for the encoder distance ("user")
  double command_rate_hz = 20;           ///< car_cmd rate [Hz of the node's clock]
  double connect_wait_s = 10;            ///< wait for the kinematics node and inputs [wall s]
  double timeout_factor = 3;             ///< a drive fails after this × distance / speed [s]
  std::string result_file;               ///< optional YAML with the drifts (written atomically)

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

struct StraightRun {
  double speed_mps = 0;
  double drift_m = 0;      ///< signed lateral offset at distance_m (positive: left)
  double heading_rad = 0;  ///< heading at the end relative to the start ("ground_truth")
  double duration_s = 0;
  bool reached = true;  ///< false: it turned away before distance_m (drift_m: where it was then)
};

class ValidateStraightNode {
 public:
  ValidateStraightNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Drives every speed; returns the runs; throws on failure.
  std::vector<StraightRun> run();

 private:
  void connect();
  void command(double v_mps);
  void stop();
  /// Drives at v (negative: backwards) until `distance_m` from the start; fills `out` when given.
  void drive(double v_mps, double distance_m, StraightRun* out);
  double encoderDistanceM() const;
  double askUserCm(double speed_mps) const;
  void writeResult(const std::vector<StraightRun>& runs) const;
  bool passed(const StraightRun& r) const;

  ros::NodeHandle nh_, pnh_;
  ValidateStraightOptions options_;
  ros_layer::StatusPublisher status_;
  ros::Publisher car_cmd_pub_;
  ros::Subscriber truth_sub_;
  std::unique_ptr<ros_layer::EncoderInput> encoders_;
  std::exception_ptr error_;
  bool have_truth_ = false;
  Pose2D truth_;
  ros::Time truth_stamp_;
  int left_ = 0, right_ = 0, resolution_ = 0;
  bool have_encoders_ = false;
};

}  // namespace wheels
}  // namespace autocal
