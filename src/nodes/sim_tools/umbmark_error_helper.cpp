// umbmark_error_helper — the simulator's tape measure for odometry_calibration_node's UMBmark
// squares: when the node's status says a square waits for its return error (phase
// odometry/umbmark_cw or odometry/umbmark_ccw, figure awaiting_error 1), it takes the axle centre's
// pose on sim/ground_truth at the square's start (figure run_start_s, when the robot still stood)
// and now (the robot has stopped), expresses the end in the start pose's frame and subtracts the
// square's computed end (figures computed_x_m, computed_y_m): ε = actual − computed (umbmark.h),
// published on odometry_calibration_node/return_error (geometry_msgs/Point, metres).
// A validation tool that stands for the person with a tape measure on a robot, not part of the
// calibration; only the simulator launches it.
#include <geometry_msgs/Point.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <deque>
#include <set>

#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"

namespace {

struct Stamped {
  double t_s, x_m, y_m, yaw_rad;
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
      nh.advertise<geometry_msgs::Point>("odometry_calibration_node/return_error", 5);
  auto truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& msg) {
        const auto& q = msg->pose.pose.orientation;
        truth.push_back({msg->header.stamp.toSec(), msg->pose.pose.position.x,
                         msg->pose.pose.position.y,
                         std::atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))});
        while (truth.size() > 2 && truth.front().t_s < truth.back().t_s - 600) truth.pop_front();
      });
  auto status_sub = nh.subscribe<autocal::CalibrationStatus>(
      "calibration/status", 20, [&](const autocal::CalibrationStatus::ConstPtr& msg) {
        if ((msg->phase != "odometry/umbmark_cw" && msg->phase != "odometry/umbmark_ccw") ||
            figure(*msg, "awaiting_error") != 1.0) {
          return;
        }
        const int square = static_cast<int>(figure(*msg, "squares_driven"));
        const double start_s = figure(*msg, "run_start_s");
        const double computed_x = figure(*msg, "computed_x_m"),
                     computed_y = figure(*msg, "computed_y_m");
        if (answered.count(square) || truth.empty() || !std::isfinite(start_s) ||
            !std::isfinite(computed_x) || !std::isfinite(computed_y)) {
          return;
        }
        const Stamped* start = nullptr;
        for (const auto& s : truth)
          if (s.t_s <= start_s) start = &s;
        if (!start) {
          ROS_ERROR("umbmark_error_helper: no ground truth at the square's start (%.2f s)",
                    start_s);
          return;
        }
        const Stamped& end = truth.back();
        const double dx = end.x_m - start->x_m, dy = end.y_m - start->y_m;
        const double c = std::cos(start->yaw_rad), s = std::sin(start->yaw_rad);
        geometry_msgs::Point error;
        error.x = c * dx + s * dy - computed_x;
        error.y = -s * dx + c * dy - computed_y;
        ROS_INFO(
            "umbmark_error_helper: %s square %d: return error (%.4f, %.4f) m (ground truth from "
            "%.2f s to %.2f s)",
            msg->phase.c_str(), square, error.x, error.y, start->t_s, end.t_s);
        pub.publish(error);
        answered.insert(square);
      });
  while (autocal::ros_layer::ok()) {
    ros::spinOnce();
    ros::WallDuration(0.005).sleep();
  }
}

}  // namespace

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "umbmark_error_helper";
  options.phase = "odometry/helper";
  options.status_topic = "umbmark_error_helper/status";  // not the calibration's own topic
  options.commands_wheels = false;
  options.interrupt_is_failure = false;
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle) { runHelper(nh); });
}
