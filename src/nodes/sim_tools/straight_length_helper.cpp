// straight_length_helper — the simulator's tape measure for odometry_calibration_node: when the
// node's status says a straight run waits for its length (phase odometry/straight, figure
// awaiting_length 1), it publishes the distance the robot's axle centre travelled from the run's
// start (figure run_start_s, when the robot still stood) to now (the robot has stopped) according
// to sim/ground_truth, on odometry_calibration_node/straight_length (std_msgs/Float64).
// A validation tool that stands for the person with a tape measure on a robot, not part of the
// calibration; only the simulator launches it.
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>

#include <cmath>
#include <deque>
#include <set>

#include "autocal/errors.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"

namespace {

struct Stamped {
  double t_s, x_m, y_m;
};

double figure(const autocal::CalibrationStatus& msg, const std::string& name) {
  for (size_t i = 0; i < msg.figure_names.size() && i < msg.figure_values.size(); ++i)
    if (msg.figure_names[i] == name) return msg.figure_values[i];
  return NAN;
}

void runHelper(ros::NodeHandle nh) {
  std::deque<Stamped> truth;
  std::set<int> answered;
  ros::Publisher pub =
      nh.advertise<std_msgs::Float64>("odometry_calibration_node/straight_length", 5);
  auto truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& msg) {
        truth.push_back(
            {msg->header.stamp.toSec(), msg->pose.pose.position.x, msg->pose.pose.position.y});
        while (truth.size() > 2 && truth.front().t_s < truth.back().t_s - 600) truth.pop_front();
      });
  auto status_sub = nh.subscribe<autocal::CalibrationStatus>(
      "calibration/status", 20, [&](const autocal::CalibrationStatus::ConstPtr& msg) {
        if (msg->phase != "odometry/straight" || figure(*msg, "awaiting_length") != 1.0) return;
        const int run = static_cast<int>(figure(*msg, "straight_run"));
        const double start_s = figure(*msg, "run_start_s");
        if (answered.count(run) || truth.empty() || !std::isfinite(start_s)) return;
        const Stamped* start = nullptr;
        for (const auto& s : truth)
          if (s.t_s <= start_s) start = &s;
        if (!start) {
          ROS_ERROR("straight_length_helper: no ground truth at the run's start (%.2f s)", start_s);
          return;
        }
        const Stamped& end = truth.back();
        std_msgs::Float64 length;
        length.data = std::hypot(end.x_m - start->x_m, end.y_m - start->y_m);
        ROS_INFO(
            "straight_length_helper: straight run %d: %.4f m (ground truth from %.2f s to "
            "%.2f s)",
            run, length.data, start->t_s, end.t_s);
        pub.publish(length);
        answered.insert(run);
      });
  while (autocal::ros_layer::ok()) {
    ros::spinOnce();
    ros::WallDuration(0.005).sleep();
  }
}

}  // namespace

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "straight_length_helper";
  options.phase = "odometry/helper";
  options.status_topic = "straight_length_helper/status";  // not the calibration's own topic
  options.commands_wheels = false;
  options.interrupt_is_failure = false;
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle) { runHelper(nh); });
}
