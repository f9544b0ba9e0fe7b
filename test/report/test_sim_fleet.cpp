// sim_fleet.test: every robot of the fleet calibrated in one simulator, each judged against its
// own robot config's truth (which no node reads): fx, fy within 0.5 %, the trim within 0.005 of
// what its true wheels need; and fleet_report_node's end (fleet/status DONE).
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include "autocal/CalibrationStatus.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"
#include "support/ros_wait.h"
#include "support/test_params.h"
#include "support/wheels_in_sim.h"

namespace {

namespace fs = std::filesystem;
using autocal::YamlMap;
using autocal::test::spinUntil;
using autocal::test::testParam;

TEST(SimFleet, EveryRobotCalibratedAgainstItsOwnTruth) {
  const fs::path root = testParam<std::string>("root");
  const std::vector<std::string> configs =
      autocal::splitCommaList(testParam<std::string>("robot_configs"));
  // An earlier test run's files (the nodes write their files only at their ends).
  ASSERT_TRUE(autocal::test::removeTree(root));
  ros::NodeHandle nh;
  std::optional<autocal::CalibrationStatus> fleet_end;
  ros::Subscriber sub = nh.subscribe<autocal::CalibrationStatus>(
      "/fleet/status", 10, [&](const autocal::CalibrationStatus::ConstPtr& m) {
        if (m->state != autocal::CalibrationStatus::STATE_RUNNING) fleet_end = *m;
      });
  for (size_t i = 0; i < configs.size(); ++i) {
    const std::string veh = "robot" + std::to_string(i + 1);
    const fs::path summary = root / "report" / veh / "summary.yaml";
    ASSERT_TRUE(spinUntil([&] { return fs::exists(summary); }, 500.0)) << summary;
    YamlMap s = YamlMap::loadFile(summary.string());
    ASSERT_EQ(s.required<std::string>("result"), "success")
        << veh << ": " << s.required<std::string>("failure");
    const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(configs[i]);
    YamlMap camera = YamlMap::loadFile((root / "camera_intrinsic" / (veh + ".yaml")).string());
    const std::vector<double> k = camera.map("camera_matrix").required<std::vector<double>>("data");
    ASSERT_EQ(k.size(), 9u);
    const autocal::wheels::KinematicsParams kin =
        autocal::wheels::readKinematicsFile((root / "kinematics" / (veh + ".yaml")).string());
    const double k_true = (robot.motor_gain_left * robot.wheel_radius_left) /
                          (robot.motor_gain_right * robot.wheel_radius_right);
    const double trim_true = autocal::wheels::trimFromSpeedRatio(k_true, kin.gain);
    std::cout << veh << " (" << configs[i] << "): fx " << k[0] << " (" << robot.camera.truth.fx
              << "), fy " << k[4] << " (" << robot.camera.truth.fy << "), trim " << kin.trim << " ("
              << trim_true << ")" << std::endl;
    EXPECT_NEAR(k[0], robot.camera.truth.fx, 0.005 * robot.camera.truth.fx) << veh;
    EXPECT_NEAR(k[4], robot.camera.truth.fy, 0.005 * robot.camera.truth.fy) << veh;
    EXPECT_NEAR(kin.trim, trim_true, 0.01) << veh;
    for (const auto& d : autocal::test::straightDrifts(robot, kin)) {
      std::cout << "drift over 2 m at " << d.speed_mps << " m/s: " << d.drift_m << " m"
                << std::endl;
      EXPECT_LE(d.drift_m, d.bound_m) << veh << " at " << d.speed_mps << " m/s";
    }
  }
  ASSERT_TRUE(spinUntil([&] { return fleet_end.has_value(); }, 30.0))
      << "fleet_report_node did not end";
  EXPECT_EQ(fleet_end->state, autocal::CalibrationStatus::STATE_DONE) << fleet_end->failure_reason;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_fleet");
  return RUN_ALL_TESTS();
}
