// run_report_node for a person watching (run_report_node.test): this test plays the stages on
// calibration/status and the encoders, and checks what the node publishes on /diagnostics (one
// status per stage: OK while running or done, WARN when the stage the run waits on is silent,
// ERROR with the reason when it failed) and on calibration/believed_path (the encoders' dead
// reckoning, against the closed form). No simulator: the node's clock is the wall clock here, and
// the waits are for messages, with a wall-clock budget only against a hung node.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "autocal/report/run_report.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::CalibrationStatus;
using autocal::dtmsg::WheelEncoderStamped;
using autocal::test::spinUntil;
using autocal::test::testParam;
using diagnostic_msgs::DiagnosticStatus;

std::string levelName(int level) {
  switch (level) {
    case DiagnosticStatus::OK:
      return "OK";
    case DiagnosticStatus::WARN:
      return "WARN";
    case DiagnosticStatus::ERROR:
      return "ERROR";
    default:
      return "STALE";
  }
}

class RunReportNodeTest : public testing::Test {
 protected:
  void SetUp() override {
    veh_ = testParam<std::string>("veh");
    nh_ = ros::NodeHandle(veh_);
    diag_sub_ = ros::NodeHandle().subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 100, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
          for (const DiagnosticStatus& s : m->status) latest_[s.name] = s;
        });
    path_sub_ = nh_.subscribe<nav_msgs::Path>(
        "calibration/believed_path", 10, [this](const nav_msgs::Path::ConstPtr& m) { path_ = m; });
    status_pub_ = nh_.advertise<CalibrationStatus>("calibration/status", 10);
    left_pub_ = nh_.advertise<WheelEncoderStamped>("left_wheel_encoder_node/tick", 100);
    right_pub_ = nh_.advertise<WheelEncoderStamped>("right_wheel_encoder_node/tick", 100);
    ASSERT_TRUE(spinUntil(
        [&] {
          return diag_sub_.getNumPublishers() > 0 && path_sub_.getNumPublishers() > 0 &&
                 status_pub_.getNumSubscribers() > 0 && left_pub_.getNumSubscribers() > 0 &&
                 right_pub_.getNumSubscribers() > 0;
        },
        60.0))
        << "run_report_node is not connected";
  }

  /// The diagnostic status of `task` ("camera", "wheels", "run") of run_report_node.
  std::string name(const std::string& task) const { return veh_ + "/run_report_node: " + task; }

  /// Waits until the latest status of `task` has `level` and its message contains `text`.
  ::testing::AssertionResult waitFor(const std::string& task, int level, const std::string& text) {
    const auto matches = [&] {
      const auto it = latest_.find(name(task));
      return it != latest_.end() && it->second.level == level &&
             it->second.message.find(text) != std::string::npos;
    };
    if (spinUntil(matches, 30.0)) return ::testing::AssertionSuccess();
    const auto it = latest_.find(name(task));
    return ::testing::AssertionFailure()
           << "no " << levelName(level) << " '" << text << "' for " << name(task) << "; last: "
           << (it == latest_.end() ? std::string("none")
                                   : levelName(it->second.level) + " '" + it->second.message + "'");
  }

  void status(const std::string& phase, uint8_t state, double progress, const std::string& text,
              const std::string& failure = "") {
    CalibrationStatus m;
    m.header.stamp = ros::Time::now();
    m.phase = phase;
    m.state = state;
    m.progress = static_cast<float>(progress);
    m.text = text;
    m.failure_reason = failure;
    status_pub_.publish(m);
  }

  void encoder(ros::Publisher& pub, const ros::Time& stamp, int ticks) {
    WheelEncoderStamped m;
    m.header.stamp = stamp;
    m.data = ticks;
    m.resolution = kTicksPerRevolution;
    m.type = WheelEncoderStamped::ENCODER_TYPE_INCREMENTAL;
    pub.publish(m);
  }

  static constexpr int kTicksPerRevolution = 135;
  std::string veh_;
  ros::NodeHandle nh_;
  ros::Subscriber diag_sub_, path_sub_;
  ros::Publisher status_pub_, left_pub_, right_pub_;
  std::map<std::string, DiagnosticStatus> latest_;
  nav_msgs::Path::ConstPtr path_;
};

TEST_F(RunReportNodeTest, DiagnosticsFollowTheStagesAndTheBelievedPathTheEncoders) {
  using S = CalibrationStatus;
  status("camera/collect", S::STATE_RUNNING, 0.3, "2 views");
  EXPECT_TRUE(waitFor("camera", DiagnosticStatus::OK, "camera/collect 30 %: 2 views"));
  EXPECT_TRUE(waitFor("wheels", DiagnosticStatus::OK, "pending"));
  EXPECT_TRUE(waitFor("run", DiagnosticStatus::OK, "running: the camera stage"));
  // The camera stage says nothing for longer than ~silent_warn_s.
  EXPECT_TRUE(waitFor("camera", DiagnosticStatus::WARN, "silent for"));

  // The encoders, one wheel moving at a time (forward, then a pivot), both wheels' readings of an
  // instant with its stamp, each 0.1 s after the last (the node keeps one every 0.05 s): the node
  // pairs the two topics' readings by their stamps. The next instant goes out once the path shows
  // the last one.
  std::vector<autocal::report::EncoderSample> sent;
  const ros::Time t0 = ros::Time::now();
  int left = 0, right = 0;
  encoder(left_pub_, t0, left);
  encoder(right_pub_, t0, right);
  sent.push_back({t0.toSec(), double(left), double(right)});
  ASSERT_TRUE(spinUntil([&] { return path_ && path_->poses.size() == 1; }, 30.0));
  for (int i = 1; i <= 18; ++i) {
    const bool left_wheel = i % 2 == 1;
    const int step = i <= 12 ? 10 : (left_wheel ? -5 : 5);
    (left_wheel ? left : right) += step;
    const ros::Time stamp = t0 + ros::Duration(0.1 * i);
    encoder(left_pub_, stamp, left);
    encoder(right_pub_, stamp, right);
    sent.push_back({stamp.toSec(), double(left), double(right)});
    ASSERT_TRUE(spinUntil([&] { return path_ && path_->poses.size() == sent.size(); }, 30.0))
        << "the believed path did not reach " << sent.size()
        << " poses (last: " << (path_ ? path_->poses.size() : 0) << ")";
  }
  // The path the core integrates from these readings with the node's wheels (the core's own
  // test checks the integration).
  autocal::report::RunRecord record;
  record.encoders = sent;
  record.ticks_per_revolution = kTicksPerRevolution;
  const std::vector<autocal::report::PathPoint> expected = autocal::report::believedPath(
      record, testParam<double>("wheel_radius_m"), testParam<double>("baseline_m"));
  ASSERT_EQ(path_->poses.size(), expected.size());
  EXPECT_EQ(path_->header.frame_id, veh_ + "/odom");
  EXPECT_GT(expected.back().pose.x_m, 0.05);
  EXPECT_GT(std::abs(expected.back().pose.yaw_rad), 0.2);
  for (size_t i = 0; i < expected.size(); ++i) {
    const geometry_msgs::PoseStamped& p = path_->poses[i];
    EXPECT_NEAR(p.pose.position.x, expected[i].pose.x_m, 1e-9) << i;
    EXPECT_NEAR(p.pose.position.y, expected[i].pose.y_m, 1e-9) << i;
    EXPECT_NEAR(autocal::ros_layer::quaternionToYaw(p.pose.orientation), expected[i].pose.yaw_rad,
                1e-9)
        << i;
    EXPECT_NEAR(p.header.stamp.toSec(), expected[i].t_s, 1e-6) << i;
  }

  status("camera/write", S::STATE_DONE, 1.0, "wrote /tmp/camera.yaml");
  EXPECT_TRUE(waitFor("camera", DiagnosticStatus::OK, "done: wrote /tmp/camera.yaml"));
  status("wheels/iterate", S::STATE_RUNNING, 0.5, "iteration 2");
  EXPECT_TRUE(waitFor("wheels", DiagnosticStatus::OK, "wheels/iterate 50 %: iteration 2"));
  EXPECT_TRUE(waitFor("run", DiagnosticStatus::OK, "running: the wheels stage"));
  status("wheels/iterate", S::STATE_FAILED, 0.5, "failed", "the tags went out of view");
  EXPECT_TRUE(waitFor("wheels", DiagnosticStatus::ERROR, "failed: the tags went out of view"));
  EXPECT_TRUE(waitFor("run", DiagnosticStatus::ERROR, "the tags went out of view"));
  EXPECT_TRUE(waitFor("camera", DiagnosticStatus::OK, "done"));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_run_report_node");
  return RUN_ALL_TESTS();
}
