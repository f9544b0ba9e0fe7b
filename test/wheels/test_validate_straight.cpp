// validate_straight against the truth: its DONE figures (the drift at each speed, read by the node
// from sim/ground_truth through the kinematics node) must match the same kinematics file driven on
// the simulator's core by the test itself (sim/straight_drift.h: straightDriftM).
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <map>
#include <optional>

#include "autocal/sim/config.h"
#include "autocal/sim/straight_drift.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"
#include "support/wheels_in_sim.h"

namespace {

using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(ValidateStraight, ReportsTheDriftTheTruthGives) {
  const std::string veh = testParam<std::string>("veh");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const autocal::wheels::KinematicsParams params = autocal::wheels::readKinematicsFile(
      autocal::wheels::kinematicsPath(testParam<std::string>("calibration_root"), veh));

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  ros::Subscriber sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 100, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->state != CalibrationStatus::STATE_RUNNING) end = *m;
      });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, 180.0)) << "no DONE or FAILED";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_DONE) << end->failure_reason;
  std::map<std::string, double> f;
  for (size_t i = 0; i < end->figure_names.size(); ++i)
    f[end->figure_names[i]] = end->figure_values[i];
  int runs = 0;
  for (int i = 0; f.count("speed_mps_" + std::to_string(i)); ++i, ++runs) {
    const double v = f["speed_mps_" + std::to_string(i)];
    const double reported_cm = f["drift_cm_" + std::to_string(i)];
    const double truth_cm = 100 * autocal::sim::straightDriftM(robot, params, v);
    std::cout << v << " m/s: validate_straight " << reported_cm << " cm, the core " << truth_cm
              << " cm" << std::endl;
    // The file leaves the robot clearly crooked; both drives start from rest through the same
    // kinematics, the node's only differ by the command latency.
    EXPECT_GT(truth_cm, 3.0) << "the test's kinematics file should make the robot drift";
    EXPECT_NEAR(std::abs(reported_cm), truth_cm, 0.5 + 0.05 * truth_cm) << "at " << v << " m/s";
  }
  EXPECT_EQ(runs, 2);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_validate_straight");
  return RUN_ALL_TESTS();
}
