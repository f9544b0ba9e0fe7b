// odometry_calibration_node in the simulator through ROS (odometry_sim.launch), judged by the
// truth the test reads from the robot config (the node never reads it): the written
// odometry/<veh>.yaml's Ed, wheelbase and distances per pulse against the config's wheel radii and
// wheelbase. Tolerances are the .test file's parameters. See odometry_node.test.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>

#include "autocal/odometry/calibration_file.h"
#include "autocal/sim/config.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

namespace fs = std::filesystem;
using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(OdometryNode, WritesTheTrueWheelsFromTheUahExperiments) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  // An earlier test run's files (the node writes its file only at its end, minutes from now).
  ASSERT_TRUE(autocal::test::removeTree(root));

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  int phases_seen = 0;
  std::string last_phase;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->phase != last_phase) ++phases_seen, last_phase = m->phase;
        if (m->state == CalibrationStatus::STATE_FAILED ||
            (m->phase.rfind("odometry/", 0) == 0 && m->state == CalibrationStatus::STATE_DONE))
          end = *m;
      });
  // Where the robot truly was at the end: said with a failure (a stall, an obstacle).
  nav_msgs::Odometry truth;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) { truth = *m; });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, testParam<double>("wall_budget_s")))
      << "no DONE or FAILED from odometry_calibration_node";
  const auto& q = truth.pose.pose.orientation;
  ASSERT_EQ(end->state, CalibrationStatus::STATE_DONE)
      << end->phase << ": " << end->failure_reason << "; the robot's true pose at the end: x "
      << truth.pose.pose.position.x << " m, y " << truth.pose.pose.position.y << " m, yaw "
      << 2 * std::atan2(q.z, q.w) * 180 / M_PI << " deg (sim time " << truth.header.stamp.toSec()
      << " s)";
  std::cout << "odometry: " << end->text << std::endl;
  for (size_t i = 0; i < end->figure_names.size(); ++i)
    std::cout << "  " << end->figure_names[i] << " " << end->figure_values[i] << std::endl;
  EXPECT_GE(phases_seen, 5) << "the status did not go through the experiments";

  const std::string path = autocal::odometry::odometryCalibrationPath(root, veh);
  ASSERT_EQ(end->text, "wrote " + path);
  const YAML::Node file = YAML::LoadFile(path);
  EXPECT_EQ(file["method"].as<std::string>(), "uah");
  const double c = 2 * M_PI / robot.encoder_resolution;
  const double e_Ed =
      file["Ed"].as<double>() / (robot.wheel_radius_right / robot.wheel_radius_left) - 1;
  const double e_b = file["b"].as<double>() / robot.wheelbase - 1;
  const double e_cR = file["right_m_per_pulse"].as<double>() / (c * robot.wheel_radius_right) - 1;
  const double e_cL = file["left_m_per_pulse"].as<double>() / (c * robot.wheel_radius_left) - 1;
  std::cout << "errors against the truth: Ed " << 100 * e_Ed << " %, b " << 100 * e_b << " %, c_R "
            << 100 * e_cR << " %, c_L " << 100 * e_cL << " %" << std::endl;
  EXPECT_LT(std::abs(e_Ed), testParam<double>("max_Ed_error"));
  EXPECT_LT(std::abs(e_b), testParam<double>("max_wheelbase_error"));
  EXPECT_LT(std::abs(e_cR), testParam<double>("max_m_per_pulse_error"));
  EXPECT_LT(std::abs(e_cL), testParam<double>("max_m_per_pulse_error"));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_odometry_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
