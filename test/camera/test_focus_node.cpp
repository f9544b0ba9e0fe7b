// The focus assistant in the simulator (focus.test), in real time: the test turns the simulated
// lens's focus ring (a parameter of the simulator, in the robot's namespace) through its sharp
// point, which it reads from the robot config (the truth; the node never reads it), and checks the
// node's published sharpness: it peaks where the lens is sharp, falls off on both sides, and the
// node's best is the peak. The robot stands still throughout (ground truth), and nothing commands
// its wheels.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

double figure(const CalibrationStatus& s, const std::string& name) {
  for (size_t i = 0; i < s.figure_names.size() && i < s.figure_values.size(); ++i)
    if (s.figure_names[i] == name) return s.figure_values[i];
  return std::nan("");
}

TEST(FocusNode, SharpnessPeaksWhereTheLensIsSharp) {
  const std::string veh = testParam<std::string>("veh");
  const double sharp_turns = autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"))
                                 .camera.focus_ring_sharp_turns;
  ros::NodeHandle nh(veh);
  std::vector<CalibrationStatus> statuses;
  std::optional<nav_msgs::Odometry> first_truth, truth;
  int wheel_commands = 0;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "focus/status", 100, [&](const CalibrationStatus::ConstPtr& m) { statuses.push_back(*m); });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) {
        if (!first_truth) first_truth = *m;
        truth = *m;
      });
  ros::Subscriber wheels_sub = nh.subscribe<autocal::dtmsg::WheelsCmdStamped>(
      "wheels_driver_node/wheels_cmd", 10,
      [&](const autocal::dtmsg::WheelsCmdStamped::ConstPtr&) { ++wheel_commands; });
  ASSERT_TRUE(
      spinUntil([&] { return !statuses.empty() && figure(statuses.back(), "board") == 1.0; }, 90.0))
      << "the node never saw the board";

  // The ring from half a turn before the sharp point to 0.7 after, in steps of 0.15: the sharp
  // point lies 0.05 from the fourth.
  struct Setting {
    double ring_turns, sharpness;
  };
  std::vector<Setting> settings;
  for (int k = 0; k < 9; ++k) {
    const double ring = sharp_turns - 0.5 + 0.15 * k;
    nh.setParam("sim_lens/focus_ring_turns", ring);
    // Readings of frames taken after the change: statuses stamped half a second later (the
    // frames' transport, the node's queue), three of them.
    const ros::Time changed = ros::Time::now();
    std::vector<double> readings;
    const size_t seen = statuses.size();
    ASSERT_TRUE(spinUntil(
        [&] {
          readings.clear();
          for (size_t i = seen; i < statuses.size(); ++i) {
            const CalibrationStatus& s = statuses[i];
            if (s.header.stamp >= changed + ros::Duration(0.5) && figure(s, "board") == 1.0)
              readings.push_back(figure(s, "sharpness"));
          }
          return readings.size() >= 3;
        },
        30.0))
        << "no board readings at ring " << ring;
    std::sort(readings.begin(), readings.end());
    settings.push_back({ring, readings[readings.size() / 2]});
    std::printf("ring %+.2f turns (sharp at %+.2f): sharpness %.3f\n", ring, sharp_turns,
                settings.back().sharpness);
  }
  const auto peak = std::max_element(
      settings.begin(), settings.end(),
      [](const Setting& a, const Setting& b) { return a.sharpness < b.sharpness; });
  // The peak is at the setting nearest the sharp point, or its neighbour (0.05 and 0.1 turns off
  // blur by less than half a pixel).
  EXPECT_LE(std::abs(peak->ring_turns - sharp_turns), 0.1 + 1e-9) << "peak at " << peak->ring_turns;
  // Half a turn off, the board is clearly softer on both sides.
  EXPECT_LT(settings.front().sharpness, 0.75 * peak->sharpness);
  EXPECT_LT(settings.back().sharpness, 0.75 * peak->sharpness);
  // The node's best is the peak it showed (its best may come from a frame between statuses).
  const double best = figure(statuses.back(), "best");
  EXPECT_GE(best, peak->sharpness - 1e-9);
  EXPECT_LE(best, 1.1 * peak->sharpness);
  // The robot stood still, and nothing drove it.
  EXPECT_EQ(wheel_commands, 0);
  ASSERT_TRUE(first_truth && truth);
  EXPECT_LT(std::hypot(truth->pose.pose.position.x - first_truth->pose.pose.position.x,
                       truth->pose.pose.position.y - first_truth->pose.pose.position.y),
            1e-3);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_focus_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
