// The camera and wheel stages' nodes in the simulator, judged by what the test can check without
// the nodes' word: the kinematics file driven on the robot config's TRUE robot (2 m straight at
// several speeds, on the simulator's core), and where the simulator's ground truth says the robot
// ended. See wheel_node.test.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <filesystem>
#include <optional>

#include "autocal/sim/config.h"
#include "autocal/sim/straight_drift.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"
#include "support/wheels_in_sim.h"

namespace {

namespace fs = std::filesystem;
using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(WheelNode, CalibratesTheTrimAndLeavesTheTagField) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const autocal::sim::WorldConfig world =
      autocal::sim::loadWorldConfig(testParam<std::string>("world_config"));
  ASSERT_TRUE(autocal::test::removeTree(root));

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  std::optional<nav_msgs::Odometry> truth;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000, [&](const CalibrationStatus::ConstPtr& m) {
        const bool wheels = m->phase.rfind("wheels/", 0) == 0;
        if (m->state == CalibrationStatus::STATE_FAILED ||
            (wheels && m->state == CalibrationStatus::STATE_DONE))
          end = *m;
      });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { truth = *m; });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, 560.0))
      << "no DONE or FAILED from the stages";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_DONE) << end->phase << ": " << end->failure_reason;
  std::cout << "wheels: " << end->text << std::endl;
  for (size_t i = 0; i < end->figure_names.size(); ++i)
    std::cout << "  " << end->figure_names[i] << " " << end->figure_values[i] << std::endl;

  // The file, driven on the true robot.
  const std::string path = autocal::wheels::kinematicsPath(root, veh);
  const autocal::wheels::KinematicsParams params = autocal::wheels::readKinematicsFile(path);
  const double v_cal = testParam<double>("calibration_speed");
  for (double v : {0.15, v_cal, 0.4}) {
    const double drift = autocal::sim::straightDriftM(robot, params, v);
    std::cout << "drift over 2 m at " << v << " m/s: " << drift * 100 << " cm" << std::endl;
    EXPECT_LE(drift, v == v_cal ? testParam<double>("max_drift_calibration_m")
                                : testParam<double>("max_drift_other_m"))
        << "at " << v << " m/s (trim " << params.trim << ")";
  }
  for (size_t i = 0; i < end->figure_names.size(); ++i) {
    if (end->figure_names[i] == "drives") {
      EXPECT_LE(end->figure_values[i], testParam<int>("max_drives"));
    }
  }

  // Where the robot ended: past the tag field, heading into the lane (−x), standing still.
  const double t_end = end->header.stamp.toSec();
  ASSERT_TRUE(spinUntil([&] { return truth && truth->header.stamp.toSec() > t_end + 1.0; }, 60.0));
  const autocal::Pose2D pose = autocal::ros_layer::fromPoseMsg(truth->pose.pose);
  double last_x = 0;
  for (const auto& t : world.floor_tags) last_x = std::min(last_x, t.pose.x_m - t.size_m / 2);
  EXPECT_LT(pose.x_m, last_x) << "the robot did not leave the tag field";
  EXPECT_LT(std::abs(std::remainder(pose.yaw_rad - M_PI, 2 * M_PI)),
            testParam<double>("max_heading_error_rad"));
  EXPECT_LT(std::hypot(truth->twist.twist.linear.x, truth->twist.twist.linear.y), 0.001)
      << "the wheels still turn";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_wheel_node");
  return RUN_ALL_TESTS();
}
