// kinematics_node — Duckietown's inverse kinematics node in C++: car commands (v, ω) in, wheel
// duties out, through wheels::carCmdToDuties with the robot's `kinematics/<veh>.yaml` (gain, trim,
// ... and autocal's deadband offsets). doc/nodes/kinematics_node.md lists topics and
// parameters.
//
// Subscribes kinematics_node/car_cmd, publishes wheels_driver_node/wheels_cmd (both relative to
// the robot's namespace). The file is read once at the start (missing: the defaults and a
// warning; malformed: a ConfigError for runNode's failure path); its values are then set as the
// private parameters ~gain ~trim ~baseline ~radius ~k ~limit ~v_max ~omega_max ~deadband_left
// ~deadband_right, which are polled every ~param_poll_s as Duckietown's node does: a valid change
// is applied, a bad one is refused with a warning and the parameter set back. ~save_calibration
// writes the values in use to the file, atomically, with calibration_time.
#pragma once

#include <ros/ros.h>
#include <std_srvs/Empty.h>

#include <string>

#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace wheels {

struct KinematicsNodeOptions {
  std::string veh;  ///< default: the last component of the node's namespace
  std::string calibration_root = "/data/config/calibrations";
  double param_poll_s = 1.0;  ///< period of the parameter poll [wall s]

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class KinematicsNode {
 public:
  /// Reads the options and the kinematics file, sets the parameters, connects the topics and the
  /// service. Throws ConfigError (bad option or file) or IoError (unreadable file).
  KinematicsNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Handles callbacks until ROS shuts down or a signal arrives.
  void run();

  const KinematicsParams& params() const { return params_; }

 private:
  void onCarCmd(const dtmsg::Twist2DStamped::ConstPtr& msg);
  /// Applies the valid changes of the private parameters; refuses (warns, sets back) the others.
  void pollParams();
  bool onSaveCalibration(std_srvs::Empty::Request& request, std_srvs::Empty::Response& response);

  ros::NodeHandle nh_, pnh_;
  KinematicsNodeOptions options_;
  std::string path_;
  KinematicsParams params_;
  ros::Publisher wheels_pub_;
  ros::Subscriber car_cmd_sub_;
  ros::ServiceServer save_srv_;
  ros::WallTimer poll_timer_;
};

}  // namespace wheels
}  // namespace autocal
