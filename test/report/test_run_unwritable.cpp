// A run refused before the robot moves (run_unwritable.test): an unwritable calibration_root, or a
// length given in the wrong unit. Each stage expected to fail FAILED with the expected cause (the
// parameters expect_camera and expect_wheels; empty: that stage need not fail), no calibration
// file was written, and the simulator's truth says the robot stayed at its start, still.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <string>

#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(RunUnwritable, EveryStageFailsNamingItsFolderAndTheRobotNeverMoves) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  ros::NodeHandle nh(veh);
  std::map<std::string, CalibrationStatus> failed;  // by stage: the phase's first part
  std::optional<nav_msgs::Odometry> first_truth, truth;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 100, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->state == CalibrationStatus::STATE_FAILED)
          failed[m->phase.substr(0, m->phase.find('/'))] = *m;
      });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) {
        if (!first_truth) first_truth = *m;
        truth = *m;
      });
  std::map<std::string, std::string> expected;  // by stage: a part of its failure reason
  for (const std::string stage : {"camera", "wheels"}) {
    const std::string text = testParam<std::string>("expect_" + stage);
    if (!text.empty()) expected[stage] = text;
  }
  ASSERT_FALSE(expected.empty());
  const auto all_failed = [&] {
    for (const auto& e : expected)
      if (!failed.count(e.first)) return false;
    return true;
  };
  ASSERT_TRUE(spinUntil(all_failed, 60.0)) << failed.size() << " stages failed";
  double t_end = 0;
  for (const auto& [stage, text] : expected) {
    const std::string& why = failed.at(stage).failure_reason;
    std::cout << stage << ": " << why << std::endl;
    EXPECT_NE(why.find(text), std::string::npos) << stage << ": " << why;
    t_end = std::max(t_end, failed.at(stage).header.stamp.toSec());
  }
  for (const std::string& file :
       {"/camera_intrinsic/" + veh + ".yaml", "/kinematics/" + veh + ".yaml"})
    EXPECT_FALSE(std::ifstream(root + file).good()) << root + file << " was written";
  // The robot: at its start (the world's robot_start, the origin), still, two seconds of sim time
  // after the failures.
  ASSERT_TRUE(spinUntil([&] { return truth && truth->header.stamp.toSec() > t_end + 2.0; }, 60.0));
  for (const nav_msgs::Odometry& t : {*first_truth, *truth}) {
    EXPECT_LT(std::hypot(t.pose.pose.position.x, t.pose.pose.position.y), 1e-4)
        << t.header.stamp.toSec();
    EXPECT_LT(std::abs(t.pose.pose.orientation.z), 1e-4) << t.header.stamp.toSec();
    EXPECT_LT(std::hypot(t.twist.twist.linear.x, t.twist.twist.linear.y), 1e-6);
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_run_unwritable");
  return RUN_ALL_TESTS();
}
