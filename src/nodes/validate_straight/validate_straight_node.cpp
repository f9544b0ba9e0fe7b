#include "validate_straight_node.h"

#include <nav_msgs/Odometry.h>

#include <cmath>
#include <iostream>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/wheels/straight_track.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace wheels {

void ValidateStraightOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkParam(!speeds_mps.empty(), "speeds_mps", "must list at least one speed");
  for (double v : speeds_mps)
    ros_layer::checkParam(std::isfinite(v) && v > 0 && v <= 1.0, "speeds_mps",
                          "each must be within (0, 1] m/s");
  ros_layer::checkParam(std::isfinite(distance_m) && distance_m > 0 && distance_m <= 20,
                        "distance_m", "must be within (0, 20] m");
  ros_layer::checkParam(
      source == "ground_truth" || source == "user", "source",
      "must be 'ground_truth' (simulator) or 'user' (robot), not '" + source + "'");
  ros_layer::checkParam(std::isfinite(max_drift_m) && max_drift_m > 0, "max_drift_m",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(radius_m) && radius_m > 0 && radius_m < 1, "radius_m",
                        "must be within (0, 1) m");
  ros_layer::checkParam(std::isfinite(command_rate_hz) && command_rate_hz >= 5, "command_rate_hz",
                        "must be >= 5 Hz (the wheel driver stops the wheels without commands)");
  ros_layer::checkParam(std::isfinite(connect_wait_s) && connect_wait_s >= 0, "connect_wait_s",
                        "must be >= 0");
  ros_layer::checkParam(std::isfinite(timeout_factor) && timeout_factor >= 1.2, "timeout_factor",
                        "must be >= 1.2");
}

namespace {

ValidateStraightOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "validate_straight");
  ValidateStraightOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("speeds_mps", o.speeds_mps);
  p.get("distance_m", o.distance_m);
  p.get("source", o.source);
  p.get("max_drift_m", o.max_drift_m);
  p.get("fail_above_max_drift", o.fail_above_max_drift);
  p.get("drive_back", o.drive_back);
  p.get("radius_m", o.radius_m);
  p.get("command_rate_hz", o.command_rate_hz);
  p.get("connect_wait_s", o.connect_wait_s);
  p.get("timeout_factor", o.timeout_factor);
  p.get("result_file", o.result_file);
  o.validate();
  return o;
}

std::string cm(double m) { return formatNumber(100.0 * m, 3) + " cm"; }

}  // namespace

bool ValidateStraightNode::passed(const StraightRun& r) const {
  return r.reached && std::abs(r.drift_m) <= options_.max_drift_m;
}

ValidateStraightNode::ValidateStraightNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), options_(readOptions(nh, pnh)) {
  status_ = ros_layer::StatusPublisher(nh_, "calibration/status");
  if (options_.source == "ground_truth") {
    truth_sub_ = nh_.subscribe<nav_msgs::Odometry>(
        "sim/ground_truth", 10, [this](const nav_msgs::Odometry::ConstPtr& msg) {
          truth_ = ros_layer::fromPoseMsg(msg->pose.pose);
          truth_stamp_ = msg->header.stamp;
          have_truth_ = true;
        });
  } else {
    encoders_ = std::make_unique<ros_layer::EncoderInput>(
        nh_,
        [this](const ros::Time&, int left, int right, int resolution) {
          left_ = left, right_ = right, resolution_ = resolution;
          have_encoders_ = true;
        },
        &error_);
  }
  car_cmd_pub_ = nh_.advertise<dtmsg::Twist2DStamped>("kinematics_node/car_cmd", 10);
  status_.running("validate/wait", 0, "waiting for the kinematics node and the inputs");
}

void ValidateStraightNode::connect() {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(options_.connect_wait_s);
  auto ready = [this] {
    return car_cmd_pub_.getNumSubscribers() > 0 &&
           (options_.source == "ground_truth" ? have_truth_ : have_encoders_);
  };
  while (ros_layer::ok() && !ready() && ros::WallTime::now() < end) {
    ros::spinOnce();
    if (error_) std::rethrow_exception(error_);
    ros::WallDuration(0.01).sleep();
  }
  if (!ros_layer::ok()) return;
  if (car_cmd_pub_.getNumSubscribers() == 0) {
    throw InputError("no kinematics node subscribes to " + car_cmd_pub_.getTopic() + " within " +
                     formatNumber(options_.connect_wait_s, 3) +
                     " s: start it (kinematics.launch) with the calibration to validate");
  }
  if (!ready()) {
    throw InputError(options_.source == "ground_truth"
                         ? "no pose on " + truth_sub_.getTopic() +
                               " (the simulator's truth) within ~connect_wait_s"
                         : std::string("no wheel encoder readings within ~connect_wait_s"));
  }
}

void ValidateStraightNode::command(double v_mps) {
  wheels::CarCommand c;
  c.v_mps = v_mps;
  c.omega_radps = 0;
  car_cmd_pub_.publish(ros_layer::toCarCmd(c, ros::Time::now()));
}

void ValidateStraightNode::stop() {
  // Zero, repeated, then wait until the robot has stopped (no pose change for a while).
  ros::Rate rate(options_.command_rate_hz);
  for (int i = 0; i < 5 && ros_layer::ok(); ++i) {
    command(0);
    ros::spinOnce();
    rate.sleep();
  }
  ros::Duration(0.5).sleep();
  ros::spinOnce();
}

double ValidateStraightNode::encoderDistanceM() const {
  if (resolution_ <= 0) return 0;
  return 0.5 * (left_ + right_) * 2 * M_PI * options_.radius_m / resolution_;
}

void ValidateStraightNode::drive(double v_mps, double distance_m, StraightRun* out) {
  ros::spinOnce();
  StraightTrack track(truth_);
  const double encoder_start = encoderDistanceM();
  const double sign = v_mps > 0 ? 1.0 : -1.0;
  const ros::Time start = ros::Time::now();
  const double timeout_s = options_.timeout_factor * distance_m / std::abs(v_mps);
  ros::Rate rate(options_.command_rate_hz);
  ros::Time last_truth = truth_stamp_;
  bool reached = true;
  while (ros_layer::ok()) {
    command(v_mps);
    rate.sleep();
    ros::spinOnce();
    if (error_) std::rethrow_exception(error_);
    double along = 0;
    if (options_.source == "ground_truth") {
      if (truth_stamp_ != last_truth) track.add(truth_);
      last_truth = truth_stamp_;
      along = sign * track.alongM();
    } else {
      along = sign * (encoderDistanceM() - encoder_start);
    }
    if (along >= distance_m) break;
    if ((ros::Time::now() - start).toSec() > timeout_s) {
      if (out && std::abs(along) < 0.05 * distance_m) {
        throw CalibrationError("the robot came only " + formatNumber(along, 3) + " m of " +
                               formatNumber(distance_m, 3) + " m in " + formatNumber(timeout_s, 3) +
                               " s at " + formatNumber(v_mps, 3) +
                               " m/s: is the kinematics node driving the wheels?");
      }
      // A robot this far off turns in a circle and never gets there: a failed run, not an error.
      ROS_WARN(
          "validate_straight: at %.2f m/s the robot did not get %.2f m along its start line "
          "in %.1f s (it turns: %.2f m along, %.2f m aside)",
          v_mps, distance_m, timeout_s, along, track.lateralM());
      reached = false;
      break;
    }
  }
  const double duration = (ros::Time::now() - start).toSec();
  stop();
  if (!out || !ros_layer::ok()) return;
  out->speed_mps = v_mps;
  out->duration_s = duration;
  out->reached = reached;
  if (!reached) {
    out->drift_m = options_.source == "ground_truth" ? track.lateralM() : std::nan("");
    out->heading_rad = track.headingRad();
  } else if (options_.source == "ground_truth") {
    out->drift_m = track.lateralAtM(distance_m);
    out->heading_rad = track.headingRad();
  } else {
    out->drift_m = 0.01 * askUserCm(v_mps);
    out->heading_rad = std::nan("");
  }
}

double ValidateStraightNode::askUserCm(double speed_mps) const {
  std::cout << "validate_straight: the robot drove " << formatNumber(options_.distance_m, 3)
            << " m at " << formatNumber(speed_mps, 3)
            << " m/s. Measure how far its centre is from the tape it started on, in cm (left "
               "positive), and type it: "
            << std::flush;
  std::string line;
  if (!std::getline(std::cin, line))
    throw InputError("no drift typed (stdin closed): run it with rosrun in a terminal");
  std::istringstream in(line);
  double v = NAN;
  if (!(in >> v) || !std::isfinite(v))
    throw InputError("'" + line + "' is not a number of centimetres");
  return v;
}

void ValidateStraightNode::writeResult(const std::vector<StraightRun>& runs) const {
  if (options_.result_file.empty()) return;
  std::ostringstream y;
  y << "# validate_straight: lateral drift after " << formatNumber(options_.distance_m, 4)
    << " m straight (source: " << options_.source << ")\n";
  y << "veh: " << options_.veh << "\nsource: " << options_.source
    << "\ndistance_m: " << formatNumber(options_.distance_m, 6)
    << "\nmax_drift_m: " << formatNumber(options_.max_drift_m, 6) << "\nruns:\n";
  for (const StraightRun& r : runs) {
    y << "  - {speed_mps: " << formatNumber(r.speed_mps, 6)
      << ", drift_m: " << formatNumber(r.drift_m, 6)
      << ", duration_s: " << formatNumber(r.duration_s, 6)
      << ", reached: " << (r.reached ? "true" : "false")
      << ", pass: " << (passed(r) ? "true" : "false") << "}\n";
  }
  writeFileAtomically(options_.result_file, y.str());
}

std::vector<StraightRun> ValidateStraightNode::run() {
  connect();
  std::vector<StraightRun> runs;
  ros_layer::StatusPublisher::Figures figures;
  for (size_t i = 0; i < options_.speeds_mps.size() && ros_layer::ok(); ++i) {
    const double v = options_.speeds_mps[i];
    const std::string phase = "validate/" + formatNumber(v, 3);
    status_.running(
        phase, double(i) / options_.speeds_mps.size(),
        "driving " + formatNumber(options_.distance_m, 3) + " m at " + formatNumber(v, 3) + " m/s");
    StraightRun r;
    drive(v, options_.distance_m, &r);
    if (!ros_layer::ok()) return runs;
    runs.push_back(r);
    if (r.reached) {
      ROS_INFO("validate_straight: %s over %.2f m at %.2f m/s: drift %s (%s, accepted up to %s)",
               options_.veh.c_str(), options_.distance_m, v, cm(r.drift_m).c_str(),
               passed(r) ? "PASS" : "FAIL", cm(options_.max_drift_m).c_str());
    } else {
      ROS_INFO(
          "validate_straight: %s at %.2f m/s: FAIL, turned away (%s aside, heading %.1f deg) "
          "before %.2f m",
          options_.veh.c_str(), v, cm(r.drift_m).c_str(), r.heading_rad * 180 / M_PI,
          options_.distance_m);
    }
    figures.push_back({"speed_mps_" + std::to_string(i), v});
    figures.push_back({"drift_cm_" + std::to_string(i), 100 * r.drift_m});
    if (options_.drive_back && i + 1 < options_.speeds_mps.size()) {
      status_.running(phase, (i + 0.5) / options_.speeds_mps.size(), "driving back");
      drive(-v, options_.distance_m, nullptr);
    }
  }
  if (!ros_layer::ok()) return runs;
  writeResult(runs);
  double worst = 0;
  bool all_passed = true;
  for (const StraightRun& r : runs) {
    if (std::isfinite(r.drift_m)) worst = std::max(worst, std::abs(r.drift_m));
    all_passed = all_passed && passed(r);
  }
  const std::string text = std::string(all_passed ? "" : "FAIL: ") + "worst drift " + cm(worst) +
                           " over " + formatNumber(options_.distance_m, 3) + " m (accepted up to " +
                           cm(options_.max_drift_m) + ")";
  if (!all_passed && options_.fail_above_max_drift)
    throw CalibrationError("the robot does not drive straight: " + text);
  status_.done("validate/done", text, figures);
  return runs;
}

}  // namespace wheels
}  // namespace autocal
