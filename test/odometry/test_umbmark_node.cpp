// odometry_calibration_node with ~method umbmark in the simulator through ROS (umbmark_node.test),
// judged by the truth the test reads from the robot config (the node never reads it): the written
// odometry/<veh>.yaml's method, Ed and Eb against the config's wheel radii and wheelbase, and the
// status protocol (every square through odometry/umbmark_cw and odometry/umbmark_ccw, each
// waiting for its return error). Tolerances are the .test file's parameters. And the failure path
// (umbmark_node_bad_error.test): an error given in centimetres is refused, nothing is written, the
// robot stands still. Each .test file runs its one test (--gtest_filter).
#include <geometry_msgs/Point.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>

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

double figure(const CalibrationStatus& msg, const std::string& name) {
  for (size_t i = 0; i < msg.figure_names.size() && i < msg.figure_values.size(); ++i)
    if (msg.figure_names[i] == name) return msg.figure_values[i];
  return NAN;
}

TEST(UmbmarkNode, WritesTheTrueWheelsFromTheSquares) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const int runs = testParam<int>("runs_per_direction");
  fs::remove_all(root);  // the node writes only at its end

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  std::set<std::string> awaited;  // phase/square of each wait for a return error
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000, [&](const CalibrationStatus::ConstPtr& m) {
        if (figure(*m, "awaiting_error") == 1.0)
          awaited.insert(m->phase + "/" + std::to_string(figure(*m, "squares_driven")));
        if (m->state == CalibrationStatus::STATE_FAILED ||
            (m->phase.rfind("odometry/", 0) == 0 && m->state == CalibrationStatus::STATE_DONE))
          end = *m;
      });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, testParam<double>("wall_budget_s")))
      << "no DONE or FAILED from odometry_calibration_node";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_DONE) << end->phase << ": " << end->failure_reason;
  std::cout << "umbmark: " << end->text << std::endl;
  for (size_t i = 0; i < end->figure_names.size(); ++i)
    std::cout << "  " << end->figure_names[i] << " " << end->figure_values[i] << std::endl;
  int cw = 0, ccw = 0;
  for (const auto& a : awaited) {
    if (a.rfind("odometry/umbmark_cw/", 0) == 0) ++cw;
    if (a.rfind("odometry/umbmark_ccw/", 0) == 0) ++ccw;
  }
  EXPECT_EQ(cw, runs) << "squares that waited for their return error, clockwise";
  EXPECT_EQ(ccw, runs) << "counter-clockwise";

  const std::string path = autocal::odometry::odometryCalibrationPath(root, veh);
  ASSERT_EQ(end->text, "wrote " + path);
  const YAML::Node file = YAML::LoadFile(path);
  EXPECT_EQ(file["method"].as<std::string>(), "umbmark");
  const double true_Ed = robot.wheel_radius_right / robot.wheel_radius_left;
  const double mean_radius = 0.5 * (robot.wheel_radius_left + robot.wheel_radius_right);
  const double true_Eb =
      (robot.wheelbase / mean_radius) /
      (testParam<double>("nominal_wheelbase_m") / testParam<double>("nominal_radius_m"));
  const double e_Ed = file["Ed"].as<double>() / true_Ed - 1;
  const double e_Eb = file["Eb"].as<double>() / true_Eb - 1;
  std::cout << "against the truth: Ed " << file["Ed"].as<double>() << " (true " << true_Ed << ", "
            << 100 * e_Ed << " %), Eb " << file["Eb"].as<double>() << " (true " << true_Eb << ", "
            << 100 * e_Eb << " %)" << std::endl;
  EXPECT_LT(std::abs(e_Ed), testParam<double>("max_Ed_error"));
  EXPECT_LT(std::abs(e_Eb), testParam<double>("max_Eb_error"));
}

TEST(UmbmarkNode, RefusesAnErrorGivenInCentimetres) {
  // umbmark_node_bad_error.test: no helper; the first square's error is given in centimetres.
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  fs::remove_all(root);
  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  bool given = false;
  ros::Publisher error_pub =
      nh.advertise<geometry_msgs::Point>("odometry_calibration_node/return_error", 1, true);
  std::optional<nav_msgs::Odometry> truth;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) { truth = *m; });
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000, [&](const CalibrationStatus::ConstPtr& m) {
        if (!given && figure(*m, "awaiting_error") == 1.0) {
          geometry_msgs::Point cm;
          cm.x = -20.5, cm.y = -38.6;  // centimetres
          error_pub.publish(cm);
          given = true;
        }
        if (m->state == CalibrationStatus::STATE_FAILED ||
            (m->phase.rfind("odometry/", 0) == 0 && m->state == CalibrationStatus::STATE_DONE))
          end = *m;
      });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, testParam<double>("wall_budget_s")))
      << "no DONE or FAILED from odometry_calibration_node";
  EXPECT_TRUE(given) << "the node never waited for a return error";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_FAILED) << end->text;
  std::cout << "failed: " << end->failure_reason << std::endl;
  EXPECT_NE(end->failure_reason.find("metres expected"), std::string::npos) << end->failure_reason;
  EXPECT_FALSE(fs::exists(autocal::odometry::odometryCalibrationPath(root, veh)));
  // The wheels: still one second (of sim time) after the failure.
  const double t_end = end->header.stamp.toSec();
  ASSERT_TRUE(spinUntil([&] { return truth && truth->header.stamp.toSec() > t_end + 1.0; }, 30.0));
  EXPECT_LT(std::hypot(truth->twist.twist.linear.x, truth->twist.twist.linear.y), 0.001);
  EXPECT_LT(std::abs(truth->twist.twist.angular.z), 0.01);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_umbmark_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
