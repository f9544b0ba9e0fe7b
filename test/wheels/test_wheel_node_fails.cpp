// The wheel stage's failure path, judged from outside the node: FAILED with the expected reason on
// calibration/status, no kinematics file, and the simulator's truth says the robot stands still.
// See wheel_node_fails.test.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <filesystem>
#include <optional>

#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(WheelNodeFails, FailsWithTheReasonStopsTheWheelsAndWritesNothing) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  const std::string path = autocal::wheels::kinematicsPath(root, veh);
  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  std::optional<nav_msgs::Odometry> truth;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 100, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->phase.rfind("wheels", 0) == 0 && m->state != CalibrationStatus::STATE_RUNNING)
          end = *m;
      });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) { truth = *m; });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, 180.0)) << "no DONE or FAILED";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_FAILED) << end->text;
  std::cout << "FAILED: " << end->failure_reason << std::endl;
  EXPECT_NE(end->failure_reason.find(testParam<std::string>("expect")), std::string::npos)
      << end->failure_reason;
  EXPECT_FALSE(std::filesystem::exists(path)) << path << " was written";
  // The wheels: still one second (of sim time) after the failure.
  const double t_end = end->header.stamp.toSec();
  ASSERT_TRUE(spinUntil([&] { return truth && truth->header.stamp.toSec() > t_end + 1.0; }, 60.0));
  EXPECT_LT(std::hypot(truth->twist.twist.linear.x, truth->twist.twist.linear.y), 0.001);
  EXPECT_LT(std::abs(truth->twist.twist.angular.z), 0.01);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_wheel_node_fails");
  return RUN_ALL_TESTS();
}
