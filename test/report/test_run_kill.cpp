// A calibration stage's node killed with SIGKILL mid-run, judged from outside (run_kill.test): the
// simulator's truth says the robot stops within the wheel driver's watchdog, run_report_node
// reports the run FAILED naming the dead node (status, summary.yaml and /diagnostics: OK before,
// ERROR after), and the calibration files of an earlier run (camera, kinematics, odometry) are
// byte for byte intact.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "autocal/io/atomic_file.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

namespace fs = std::filesystem;
using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

double speed(const nav_msgs::Odometry& m) {
  return std::hypot(m.twist.twist.linear.x, m.twist.twist.linear.y);
}

TEST(RunKill, TheRobotStopsTheRunFailsTheFilesAreIntact) {
  const std::string veh = testParam<std::string>("veh");
  const std::string stage = testParam<std::string>("stage");
  const fs::path root = testParam<std::string>("calibration_root");
  // The files of an earlier test run, and its report.
  ASSERT_TRUE(autocal::test::removeTree(root));
  ros::NodeHandle nh(veh);

  std::optional<CalibrationStatus> died;
  std::string stage_node;
  bool stage_active = false;
  // A MessageEvent callback (its publisher's name is the node to kill).
  const boost::function<void(const ros::MessageEvent<CalibrationStatus const>&)> on_status =
      [&](const ros::MessageEvent<CalibrationStatus const>& e) {
        const CalibrationStatus& m = *e.getMessage();
        if (m.phase.rfind(stage + "/", 0) != 0) return;
        if (m.phase == stage + "/died") {
          died = m;
        } else if (m.state == CalibrationStatus::STATE_RUNNING && m.phase != stage + "/wait") {
          stage_active = true;
          stage_node = e.getPublisherName();
        }
      };
  ros::Subscriber status_sub = nh.subscribe<const ros::MessageEvent<CalibrationStatus const>&>(
      "calibration/status", 100, on_status);
  // run_report_node's diagnostics of the stage (README "The calibration run").
  std::optional<diagnostic_msgs::DiagnosticStatus> stage_diag;
  ros::Subscriber diag_sub = ros::NodeHandle().subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const diagnostic_msgs::DiagnosticStatus& s : m->status)
          if (s.name == veh + "/run_report_node: " + stage) stage_diag = s;
      });
  std::vector<nav_msgs::Odometry> truth;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 1000,
      [&](const nav_msgs::Odometry::ConstPtr& m) { truth.push_back(*m); });

  // The stage at work and the robot moving.
  ASSERT_TRUE(spinUntil(
      [&] {
        return stage_active && !truth.empty() &&
               (speed(truth.back()) > 0.02 || std::abs(truth.back().twist.twist.angular.z) > 0.2);
      },
      150.0))
      << "the " << stage << " stage never drove the robot";

  // Files of an earlier run, which the failed run must leave as they are.
  const std::string camera_file = (root / "camera_intrinsic" / (veh + ".yaml")).string();
  const std::string kinematics_file = autocal::wheels::kinematicsPath(root.string(), veh);
  const std::string camera_text = "# an earlier calibration\nimage_width: 640\n";
  autocal::wheels::KinematicsParams earlier;
  earlier.trim = 0.0421;
  const std::string kinematics_text = autocal::wheels::kinematicsYaml(earlier, "1999-01-01");
  fs::create_directories(fs::path(camera_file).parent_path());
  fs::create_directories(fs::path(kinematics_file).parent_path());
  const std::string odometry_file = autocal::odometry::odometryCalibrationPath(root.string(), veh);
  const std::string odometry_text = "# an earlier odometry calibration\nmethod: uah\n";
  fs::create_directories(fs::path(odometry_file).parent_path());
  autocal::writeFileAtomically(camera_file, camera_text);
  autocal::writeFileAtomically(kinematics_file, kinematics_text);
  autocal::writeFileAtomically(odometry_file, odometry_text);

  // While the stage runs, its diagnostics are OK.
  ASSERT_TRUE(spinUntil([&] { return stage_diag.has_value(); }, 30.0)) << "no diagnostics";
  EXPECT_EQ(stage_diag->level, diagnostic_msgs::DiagnosticStatus::OK) << stage_diag->message;

  const int pid = autocal::ros_layer::nodePid(stage_node);
  ASSERT_GT(pid, 0) << stage_node;
  const double t_kill = truth.back().header.stamp.toSec();
  std::cout << "SIGKILL " << stage_node << " (pid " << pid << ") at sim " << t_kill
            << " s, robot at " << speed(truth.back()) << " m/s, "
            << truth.back().twist.twist.angular.z << " rad/s" << std::endl;
  ASSERT_EQ(kill(pid, SIGKILL), 0);

  // The robot: stopped (the wheel driver's watchdog, 0.5 s without wheels_cmd) and still after.
  ASSERT_TRUE(spinUntil([&] { return truth.back().header.stamp.toSec() > t_kill + 2.0; }, 60.0));
  double t_still = -1;
  for (const nav_msgs::Odometry& m : truth) {
    const double t = m.header.stamp.toSec();
    if (t <= t_kill) continue;
    const bool still = speed(m) < 0.002 && std::abs(m.twist.twist.angular.z) < 0.02;
    if (still && t_still < 0) t_still = t;
    if (!still) t_still = -1;
  }
  ASSERT_GT(t_still, 0) << "the robot did not stop after the kill";
  std::cout << "robot still " << t_still - t_kill << " s (sim) after the kill" << std::endl;
  // The watchdog's 0.5 s, then the wheels' spin-down (first-order lag).
  EXPECT_LT(t_still - t_kill, 0.5 + 0.35);

  // The run: FAILED in the dead stage's name, and a report that says so.
  ASSERT_TRUE(spinUntil([&] { return died.has_value(); }, 30.0)) << "no " << stage << "/died";
  EXPECT_EQ(died->state, CalibrationStatus::STATE_FAILED);
  EXPECT_NE(died->failure_reason.find(stage_node), std::string::npos) << died->failure_reason;
  // The diagnostics: ERROR naming the dead node.
  EXPECT_TRUE(spinUntil(
      [&] {
        return stage_diag->level == diagnostic_msgs::DiagnosticStatus::ERROR &&
               stage_diag->message.find(stage_node + " died") != std::string::npos;
      },
      30.0))
      << "diagnostics of the dead stage: level " << int(stage_diag->level) << ", "
      << stage_diag->message;
  const fs::path summary = root / "report" / veh / "summary.yaml";
  ASSERT_TRUE(spinUntil([&] { return fs::exists(summary); }, 30.0)) << summary;
  autocal::YamlMap s = autocal::YamlMap::loadFile(summary.string());
  EXPECT_EQ(s.required<std::string>("result"), "failed");
  EXPECT_NE(s.required<std::string>("failure").find("died"), std::string::npos);
  EXPECT_TRUE(fs::exists(root / "report" / veh / "report.png"));

  // The earlier files, byte for byte; no temporary file left beside them.
  EXPECT_EQ(autocal::readFile(camera_file), camera_text);
  EXPECT_EQ(autocal::readFile(kinematics_file), kinematics_text);
  EXPECT_EQ(autocal::readFile(odometry_file), odometry_text);
  for (const fs::path& dir :
       {fs::path(camera_file).parent_path(), fs::path(kinematics_file).parent_path(),
        fs::path(odometry_file).parent_path()}) {
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == veh + ".yaml") << "left in " << dir << ": " << name;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_run_kill");
  return RUN_ALL_TESTS();
}
