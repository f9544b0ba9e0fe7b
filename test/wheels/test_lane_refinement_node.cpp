// lane_refinement_node through ROS (sim_node, kinematics_node, lane_refinement_node), judged by
// the simulator's truth: with the kinematics node's trim off by ~trim_offset, the test plays the
// lane follower (it steers towards the lane centre from the truth) until the node starts a pass;
// the node then drives the segment alone. With stable_passes 1 its estimate is applied: the
// kinematics node's trim and the saved file end within ~tolerance of the true trim, and the robot's
// true path stays within ~max_lateral_m of the lane centre while the node drives.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

double figure(const CalibrationStatus& m, const std::string& name) {
  for (size_t i = 0; i < m.figure_names.size() && i < m.figure_values.size(); ++i)
    if (m.figure_names[i] == name) return m.figure_values[i];
  return std::nan("");
}

TEST(LaneRefinementNode, OnePassAppliesTheTrueTrim) {
  const std::string veh = testParam<std::string>("veh");
  const autocal::sim::RobotConfig r =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const double k =
      (r.motor_gain_left * r.wheel_radius_left) / (r.motor_gain_right * r.wheel_radius_right);
  const double truth = (k - 1) / (k + 1);  // gain 1
  const double start_trim = truth + testParam<double>("trim_offset");
  const std::string file =
      autocal::wheels::kinematicsPath(testParam<std::string>("calibration_root"), veh);
  std::remove(file.c_str());

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> status, applied;
  bool in_pass = false, pass_seen = false;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 100, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->phase.rfind("lane/", 0) != 0) return;
        status = *m;
        in_pass = m->phase == "lane/pass";
        pass_seen = pass_seen || in_pass;
        if (m->phase == "lane/applied") applied = *m;
      });
  std::optional<autocal::Pose2D> pose;
  double max_lateral_m = 0;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) {
        pose = autocal::ros_layer::fromPoseMsg(m->pose.pose);
        if (in_pass) max_lateral_m = std::max(max_lateral_m, std::abs(pose->y_m));
      });
  ros::Publisher car_cmd =
      nh.advertise<autocal::dtmsg::Twist2DStamped>("kinematics_node/car_cmd", 10);

  // The robot's kinematics: the deadbands compensated (as the wheel stage leaves them), the trim
  // off. Both nodes poll the parameter.
  nh.setParam("kinematics_node/deadband_left", r.deadband);
  nh.setParam("kinematics_node/deadband_right", r.deadband);
  nh.setParam("kinematics_node/trim", start_trim);
  ASSERT_TRUE(spinUntil(
      [&] { return status && std::abs(figure(*status, "trim") - start_trim) < 1e-9; }, 30.0))
      << "lane_refinement_node did not take the kinematics node's trim";
  // The kinematics node polls its parameters: wait until its wheels_cmd for a small turn on the
  // spot is what its parameters (all on the server) now give.
  autocal::wheels::KinematicsParams kinematics;
  for (const autocal::wheels::KinematicsField& f : autocal::wheels::kinematicsFields()) {
    ASSERT_TRUE(nh.getParam(std::string("kinematics_node/") + f.key, kinematics.*f.member)) << f.key;
  }
  autocal::wheels::CarCommand nudge;
  nudge.omega_radps = 0.05;
  const autocal::WheelDuties wanted = autocal::wheels::carCmdToDuties(kinematics, nudge);
  std::optional<autocal::WheelDuties> seen;
  ros::Subscriber wheels_sub = nh.subscribe<autocal::dtmsg::WheelsCmdStamped>(
      "wheels_driver_node/wheels_cmd", 10, [&](const autocal::dtmsg::WheelsCmdStamped::ConstPtr& m) {
        seen = autocal::ros_layer::fromWheelsCmd(*m);
      });
  int spins = 0;
  ASSERT_TRUE(spinUntil(
      [&] {
        if (seen && std::abs(seen->left - wanted.left) < 1e-6 &&
            std::abs(seen->right - wanted.right) < 1e-6) {
          return true;
        }
        if (spins++ % 5 == 0) car_cmd.publish(autocal::ros_layer::toCarCmd(nudge, ros::Time::now()));
        return false;
      },
      30.0))
      << "the kinematics node did not take the trim";
  wheels_sub.shutdown();

  // The lane follower's stand-in until the node takes over.
  ros::Time last_cmd;
  ASSERT_TRUE(spinUntil(
      [&] {
        if (pass_seen) return true;
        if (pose && ros::Time::now() - last_cmd > ros::Duration(0.03)) {
          autocal::wheels::CarCommand c;
          c.v_mps = 0.2;
          c.omega_radps = -12.0 * pose->y_m - 5.0 * std::remainder(pose->yaw_rad, 2 * M_PI);
          last_cmd = ros::Time::now();
          car_cmd.publish(autocal::ros_layer::toCarCmd(c, last_cmd));
        }
        return false;
      },
      60.0))
      << "no pass started";
  ASSERT_TRUE(spinUntil([&] { return applied.has_value() || (status && !in_pass); }, 120.0))
      << "the pass did not end";
  ASSERT_TRUE(applied.has_value()) << "nothing applied: " << status->text;
  const double trim = figure(*applied, "trim");
  std::printf("applied trim %.5f (start %.5f, true %.5f, error %+.5f), max |y| %.1f mm\n", trim,
              start_trim, truth, trim - truth, max_lateral_m * 1000);
  EXPECT_NEAR(trim, truth, testParam<double>("tolerance"));
  EXPECT_LT(max_lateral_m, testParam<double>("max_lateral_m"));
  double param = 0;
  ASSERT_TRUE(nh.getParam("kinematics_node/trim", param));
  EXPECT_DOUBLE_EQ(param, trim);
  // The kinematics node saved what it uses (the service call returned before the DONE).
  const autocal::wheels::KinematicsParams saved = autocal::wheels::readKinematicsFile(file);
  EXPECT_NEAR(saved.trim, trim, 1e-6);
  EXPECT_NEAR(saved.deadband_left, r.deadband, 1e-6);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lane_refinement_node");
  return RUN_ALL_TESTS();
}
