// The ROS layer with a master (test/ros/ros_layer.test): ParamReader fills options from private
// parameters, keeps defaults, refuses wrong types and missing required ones naming "~key"; the
// status is latched and says FAILED with the reason; WheelsCommander::stop() sends zero duties
// that a subscriber sees, and drops non-finite commands.
#include <gtest/gtest.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "autocal/errors.h"
#include "autocal/report/run_report.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/params.h"
#include "support/ros_wait.h"

using namespace autocal;
using namespace autocal::ros_layer;

namespace {

using autocal::test::spinUntil;

}  // namespace

TEST(ParamReader, FillsOptionsKeepsDefaultsAndNamesBadKeys) {
  const ParamReader p(ros::NodeHandle("~"), "test");
  double rate_hz = 1.0, missing_double = 4.5, whole = 0.0;
  int count = 0;
  bool enabled = true;
  std::string file = "default";
  p.get("rate_hz", rate_hz);
  p.get("count", count);
  p.get("enabled", enabled);
  p.get("file", file);
  p.get("whole_number_for_double", whole);
  p.get("not_set", missing_double);
  EXPECT_DOUBLE_EQ(rate_hz, 12.5);
  EXPECT_EQ(count, 7);
  EXPECT_FALSE(enabled);
  EXPECT_EQ(file, "/tmp/x.yaml");
  EXPECT_DOUBLE_EQ(whole, 3.0);
  EXPECT_DOUBLE_EQ(missing_double, 4.5) << "an unset parameter keeps its default";

  double wrong = 1.0;
  try {
    p.get("wrong_type", wrong);
    FAIL() << "a string read as a number was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("~wrong_type"), std::string::npos) << e.what();
  }
  EXPECT_DOUBLE_EQ(wrong, 1.0);
  std::string required;
  try {
    p.require("calibration_root", required);
    FAIL() << "a missing required parameter was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("~calibration_root: required parameter is missing"),
              std::string::npos)
        << e.what();
  }
  int required_count = 0;
  p.require("count", required_count);
  EXPECT_EQ(required_count, 7);
}

TEST(NodeRuntime, StatusIsLatchedAndFailedCarriesTheReason) {
  ros::NodeHandle nh("status_test");
  StatusPublisher status(nh, "calibration/status");
  status.running("camera/collect", 0.25, "collecting", {{"views", 3}});
  status.failed("camera", "no board seen in a full turn");
  // Subscribed after both were published: latched, the last one arrives.
  std::vector<CalibrationStatus> got;
  ros::Subscriber sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 10, [&](const CalibrationStatus::ConstPtr& m) { got.push_back(*m); });
  ASSERT_TRUE(spinUntil([&] { return !got.empty(); }, 10.0));
  EXPECT_EQ(got.back().state, CalibrationStatus::STATE_FAILED);
  EXPECT_EQ(got.back().phase, "camera");
  EXPECT_EQ(got.back().failure_reason, "no board seen in a full turn");
}

TEST(NodeRuntime, AStagesProgressNeverGoesBack) {
  ros::NodeHandle nh("progress_test");
  StatusPublisher status(nh, "calibration/status");
  std::vector<CalibrationStatus> got;
  ros::Subscriber sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 10, [&](const CalibrationStatus::ConstPtr& m) { got.push_back(*m); });
  ASSERT_TRUE(spinUntil([&] { return status.subscribers() > 0; }, 10.0));
  status.running("wheels/iterate", 0.45, "iteration 5");
  status.running("wheels/align", 0.1, "re-aligning");
  status.running("wheels/align", -1, "unknown");
  status.running("wheels/iterate", 0.5, "iteration 6");
  ASSERT_TRUE(spinUntil([&] { return got.size() >= 4; }, 10.0));
  EXPECT_FLOAT_EQ(got[0].progress, 0.45f);
  EXPECT_FLOAT_EQ(got[1].progress, 0.45f);
  EXPECT_LT(got[2].progress, 0.0f);
  EXPECT_FLOAT_EQ(got[3].progress, 0.5f);
}

TEST(NodeRuntime, ResumeKeepsAStageTheLastReportSaysSucceeded) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / "autocal_test_resume";
  fs::remove_all(root);
  fs::create_directories(root / "report" / "robo");
  fs::create_directories(root / "camera_intrinsic");
  const std::string camera_file = (root / "camera_intrinsic" / "robo.yaml").string();
  std::ofstream(camera_file) << "image_width: 640\n";
  // The last run: the camera stage done, the wheel stage failed.
  autocal::report::RunRecorder r("robo", {"camera", "wheels"});
  autocal::report::StatusUpdate u;
  u.phase = "camera/write";
  u.state = autocal::report::StatusUpdate::State::kDone;
  u.text = "wrote " + camera_file;
  u.file = camera_file;
  u.figures = {{"fx", 318.0}, {"min_duty_left_forward", 0.11}};
  r.addStatus(u);
  u.phase = "wheels/iterate";
  u.state = autocal::report::StatusUpdate::State::kFailed;
  u.failure_reason = "the floor tags were lost";
  r.addStatus(u);
  autocal::report::writeReport((root / "report" / "robo").string(), r.record(), "", {});

  ros::NodeHandle nh("resume_test");
  StatusPublisher status(nh, "calibration/status");
  std::vector<CalibrationStatus> got;
  ros::Subscriber sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 10, [&](const CalibrationStatus::ConstPtr& m) { got.push_back(*m); });
  EXPECT_FALSE(autocal::ros_layer::resumeStage(status, root.string(), "robo", "wheels"));
  EXPECT_FALSE(autocal::ros_layer::resumeStage(status, root.string(), "other", "camera"));
  ASSERT_TRUE(autocal::ros_layer::resumeStage(status, root.string(), "robo", "camera"));
  ASSERT_TRUE(spinUntil([&] { return !got.empty(); }, 10.0));
  EXPECT_EQ(got.back().state, CalibrationStatus::STATE_DONE);
  EXPECT_EQ(got.back().phase, "camera/resumed");
  EXPECT_EQ(got.back().text, "kept " + camera_file);
  EXPECT_EQ(got.back().file, camera_file);
  ASSERT_EQ(got.back().figure_names.size(), 2u);
  EXPECT_EQ(got.back().figure_names[1], "min_duty_left_forward");
  EXPECT_DOUBLE_EQ(got.back().figure_values[1], 0.11);
  // Its file gone: the stage runs again.
  fs::remove(camera_file);
  EXPECT_FALSE(autocal::ros_layer::resumeStage(status, root.string(), "robo", "camera"));
  fs::remove_all(root);
}

TEST(NodeRuntime, StopSendsZeroDutiesThatASubscriberSees) {
  ros::NodeHandle nh("wheels_test");
  std::vector<std::pair<float, float>> got;
  ros::Subscriber sub = nh.subscribe<dtmsg::WheelsCmdStamped>(
      "wheels_driver_node/wheels_cmd", 100, [&](const dtmsg::WheelsCmdStamped::ConstPtr& m) {
        got.emplace_back(m->vel_left, m->vel_right);
      });
  WheelsCommander wheels(nh, "wheels_driver_node/wheels_cmd");
  ASSERT_TRUE(spinUntil([&] { return sub.getNumPublishers() > 0; }, 10.0));
  wheels.command(std::nan(""), 0.5);  // dropped
  wheels.command(2.0, -0.3);          // clamped
  wheels.stop(0.3, 1.0);
  ASSERT_TRUE(spinUntil([&] { return got.size() >= 3; }, 5.0));
  EXPECT_FLOAT_EQ(got.front().first, 1.0f);
  EXPECT_FLOAT_EQ(got.front().second, -0.3f);
  int zeros = 0;
  for (const auto& d : got) {
    EXPECT_TRUE(std::isfinite(d.first) && std::isfinite(d.second));
    zeros += (d.first == 0.0f && d.second == 0.0f) ? 1 : 0;
  }
  EXPECT_GE(zeros, 2) << "the stop is repeated";
  EXPECT_EQ(got.back(), std::make_pair(0.0f, 0.0f));
}

TEST(NodeRuntime, AStageInterruptedWhileWaitingForTheOneBeforeEndsWithoutFailed) {
  ros::NodeHandle nh("waiter");
  std::vector<CalibrationStatus> got;
  ros::Subscriber sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 20, [&](const CalibrationStatus::ConstPtr& m) { got.push_back(*m); });
  ASSERT_TRUE(spinUntil([&] { return !got.empty(); }, 30.0)) << "no status from the waiting node";
  EXPECT_EQ(got.back().phase, "wheels/wait");
  const std::string node = "/waiter/wheel_calibration_node";
  const int pid = nodePid(node);
  ASSERT_GT(pid, 0) << node;
  ASSERT_EQ(::kill(pid, SIGINT), 0);
  // Gone, its last word still the wait (a FAILED would arrive before the node exits).
  ASSERT_TRUE(spinUntil([&] { return ::kill(pid, 0) != 0; }, 20.0)) << node << " did not end";
  spinUntil([] { return false; }, 0.5);
  for (const CalibrationStatus& s : got)
    EXPECT_NE(s.state, CalibrationStatus::STATE_FAILED) << s.phase << ": " << s.failure_reason;
}

// Filled from the test's start: the stage node fails within 2 x ~connect_wait_s of its start.
std::vector<CalibrationStatus> g_nodriver_status;

TEST(NodeRuntime, AStageWithNoWheelsDriverFailsBeforeDriving) {
  const std::vector<CalibrationStatus>& got = g_nodriver_status;
  ASSERT_TRUE(spinUntil(
      [&] { return !got.empty() && got.back().state == CalibrationStatus::STATE_FAILED; }, 30.0))
      << "no FAILED from the camera stage with no wheels driver";
  EXPECT_NE(got.back().failure_reason.find(
                "nobody subscribes to /nodriver/wheels_driver_node/wheels_cmd"),
            std::string::npos)
      << got.back().failure_reason;
  for (const CalibrationStatus& s : got) EXPECT_NE(s.phase, "camera/probe") << "it began to drive";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "ros_layer_test");
  ros::NodeHandle nh;
  ros::Subscriber nodriver = nh.subscribe<CalibrationStatus>(
      "/nodriver/calibration/status", 20,
      boost::function<void(const CalibrationStatus::ConstPtr&)>(
          [](const CalibrationStatus::ConstPtr& m) { g_nodriver_status.push_back(*m); }));
  return RUN_ALL_TESTS();
}
