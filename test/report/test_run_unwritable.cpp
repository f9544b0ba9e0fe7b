// A run whose calibration_root cannot be written fails before the robot moves
// (run_unwritable.test): every stage's FAILED names its output folder, and the simulator's truth
// says the robot stayed at its start, still.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
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
  const std::map<std::string, std::string> folders = {{"camera", root + "/camera_intrinsic"},
                                                      {"wheels", root + "/kinematics"}};
  ASSERT_TRUE(spinUntil([&] { return failed.count("camera") && failed.count("wheels"); }, 60.0))
      << failed.size() << " stages failed";
  for (const auto& [stage, folder] : folders) {
    const std::string& why = failed.at(stage).failure_reason;
    std::cout << stage << ": " << why << std::endl;
    EXPECT_NE(why.find(folder + ": cannot write here"), std::string::npos) << stage << ": " << why;
  }
  // The robot: at its start (the world's robot_start, the origin), still, two seconds of sim time
  // after the failures.
  const double t_end =
      std::max(failed.at("camera").header.stamp.toSec(), failed.at("wheels").header.stamp.toSec());
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
