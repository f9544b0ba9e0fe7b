#include "kinematics_node.h"

#include <ros/callback_queue.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace wheels {

namespace {

constexpr const char* kNode = "kinematics_node";

KinematicsNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, kNode);
  KinematicsNodeOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("param_poll_s", o.param_poll_s);
  o.validate();
  return o;
}

}  // namespace

void KinematicsNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty(), "veh", "must not be empty (the robot's name names the file)");
  ros_layer::checkParam(veh.find('/') == std::string::npos, "veh", "must not contain '/'");
  ros_layer::checkParam(!calibration_root.empty(), "calibration_root", "must not be empty");
  ros_layer::checkParam(std::isfinite(param_poll_s) && param_poll_s > 0, "param_poll_s",
                        "must be > 0");
}

KinematicsNode::KinematicsNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), options_(readOptions(nh, pnh)) {
  path_ = kinematicsPath(options_.calibration_root, options_.veh);
  std::error_code ec;
  if (std::filesystem::exists(path_, ec) || ec) {
    params_ = readKinematicsFile(path_);  // malformed: ConfigError, never the defaults
    ROS_INFO_STREAM(kNode << ": read " << path_ << " (keys it lacks keep their defaults)");
  } else {
    ROS_WARN_STREAM(kNode << ": no kinematics file " << path_
                          << ": using the defaults (gain 1, trim 0, Duckietown's); "
                             "~save_calibration writes one");
  }
  // The file's values become the parameters (as in Duckietown's node, they replace any set
  // before the start): the parameter server shows what is in use.
  for (const KinematicsField& f : kinematicsFields()) {
    pnh_.setParam(f.key, params_.*f.member);
    ROS_INFO_STREAM(kNode << ": ~" << f.key << " = " << formatNumber(params_.*f.member));
  }

  wheels_pub_ = nh_.advertise<dtmsg::WheelsCmdStamped>("wheels_driver_node/wheels_cmd", 1);
  car_cmd_sub_ = nh_.subscribe("kinematics_node/car_cmd", 1, &KinematicsNode::onCarCmd, this);
  save_srv_ = pnh_.advertiseService("save_calibration", &KinematicsNode::onSaveCalibration, this);
  poll_timer_ = pnh_.createWallTimer(ros::WallDuration(options_.param_poll_s),
                                     [this](const ros::WallTimerEvent&) { pollParams(); });
  ROS_INFO_STREAM(kNode << ": " << car_cmd_sub_.getTopic() << " -> " << wheels_pub_.getTopic());
}

void KinematicsNode::run() {
  while (ros_layer::ok()) ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.1));
  // On SIGINT/SIGTERM, stop the wheels while this publisher's connections still stand (it shares
  // them); runNode stops them again once the node is gone.
  if (ros_layer::interrupted()) {
    ros_layer::WheelsCommander(nh_, wheels_pub_.getTopic()).stop();
  }
}

void KinematicsNode::onCarCmd(const dtmsg::Twist2DStamped::ConstPtr& msg) {
  const CarCommand cmd = ros_layer::fromCarCmd(*msg);
  if (!std::isfinite(cmd.v_mps) || !std::isfinite(cmd.omega_radps)) {
    ROS_WARN_THROTTLE(1.0, "%s: dropped a non-finite car_cmd (v %f, omega %f)", kNode, cmd.v_mps,
                      cmd.omega_radps);
    return;
  }
  // Stamped as the command it answers, as Duckietown's node does.
  wheels_pub_.publish(ros_layer::toWheelsCmd(carCmdToDuties(params_, cmd), msg->header.stamp));
}

void KinematicsNode::pollParams() {
  KinematicsParams wanted = params_;
  std::vector<const KinematicsField*> changed;
  for (const KinematicsField& f : kinematicsFields()) {
    const double current = params_.*f.member;
    double value = current;
    if (!pnh_.getParam(f.key, value)) {
      ROS_WARN_STREAM(kNode << ": ~" << f.key << " is "
                            << (pnh_.hasParam(f.key) ? "not a number" : "not set") << ": kept "
                            << formatNumber(current));
      pnh_.setParam(f.key, current);
      continue;
    }
    if (value == current) continue;
    wanted.*f.member = value;
    changed.push_back(&f);
  }
  if (changed.empty()) return;
  auto apply = [&](const KinematicsField& f, double before) {
    ROS_INFO_STREAM(kNode << ": ~" << f.key << " = " << formatNumber(params_.*f.member) << " (was "
                          << formatNumber(before) << ")");
  };
  const KinematicsParams before = params_;
  try {
    wanted.validate();  // changes that are only valid together (gain and trim) apply together
    params_ = wanted;
    for (const KinematicsField* f : changed) apply(*f, before.*f->member);
    return;
  } catch (const ConfigError&) {
  }
  for (const KinematicsField* f : changed) {
    KinematicsParams trial = params_;
    trial.*f->member = wanted.*f->member;
    try {
      trial.validate();
      params_ = trial;
      apply(*f, before.*f->member);
    } catch (const ConfigError& e) {
      ROS_WARN_STREAM(kNode << ": ~" << f->key << " = " << formatNumber(wanted.*f->member)
                            << " refused (" << e.what() << "): kept "
                            << formatNumber(params_.*f->member));
      pnh_.setParam(f->key, params_.*f->member);
    }
  }
}

bool KinematicsNode::onSaveCalibration(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  pollParams();  // a parameter set just before the call is saved too
  try {
    const std::string time = writeKinematicsFile(path_, params_);
    ROS_INFO_STREAM(kNode << ": wrote " << path_ << " (calibration_time " << time << ", gain "
                          << formatNumber(params_.gain) << ", trim " << formatNumber(params_.trim)
                          << ")");
    return true;
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM(kNode << ": ~save_calibration failed, " << path_
                           << " is unchanged: " << e.what());
    return false;
  }
}

}  // namespace wheels
}  // namespace autocal
