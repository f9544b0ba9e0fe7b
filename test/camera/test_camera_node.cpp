// The camera stage's node in the simulator, judged by what the test can check without the node's
// word: the YAML it wrote against the robot config's TRUE lens, the robot's ground-truth motion
// after the end, and the file system. See camera_node.test.
#include <camera_calibration_parsers/parse.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>

#include "autocal/sim/config.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

namespace fs = std::filesystem;
using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CameraNode, EndsAsTheTestFileExpects) {
  const std::string veh = testParam<std::string>("veh");
  const std::string expect = testParam<std::string>("expect");
  const std::string root = testParam<std::string>("calibration_root");
  const fs::path yaml = fs::path(root) / "camera_intrinsic" / (veh + ".yaml");
  // A good file from an earlier run: a failed stage must leave it as it is.
  ASSERT_TRUE(autocal::test::removeTree(root));
  fs::create_directories(yaml.parent_path());
  const std::string earlier = "# an earlier calibration\nimage_width: 640\n";
  std::ofstream(yaml.string()) << earlier;

  ros::NodeHandle nh(veh);
  std::vector<CalibrationStatus> statuses;
  double turned_rad = 0, last_yaw = NAN;
  bool sweeping = true;
  // Only the latest ground truth: without a camera subscriber the simulator runs hundreds of
  // times faster than real time and floods it.
  std::optional<nav_msgs::Odometry> truth;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000,
      [&](const CalibrationStatus::ConstPtr& m) {
        statuses.push_back(*m);
        if (m->phase == "camera/calibrate") sweeping = false;
      });
  // The angle the robot turned through (ground truth, summed over every message) until the stage
  // asked for the fit: what the sweep cost, whatever the machine's speed.
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) {
        truth = *m;
        const auto& q = m->pose.pose.orientation;
        const double yaw = std::atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
        if (sweeping && !std::isnan(last_yaw))
          turned_rad += std::abs(std::remainder(yaw - last_yaw, 2 * M_PI));
        last_yaw = yaw;
      });
  // Bad input beside the camera's frames: corrupt JPEGs and frames of another size, stamped now
  // so that the node wants them; it must drop and count them and calibrate on the good ones.
  const bool inject = testParam<bool>("inject_bad_frames");
  ros::Publisher bad_pub;
  if (inject)
    bad_pub = nh.advertise<sensor_msgs::CompressedImage>("camera_node/image/compressed", 10);
  cv::Mat small(240, 320, CV_8UC3, cv::Scalar(90, 90, 90));
  sensor_msgs::CompressedImage corrupt, wrong_size;
  corrupt.format = wrong_size.format = "jpeg";
  cv::imencode(".jpg", small, wrong_size.data);
  corrupt.data = wrong_size.data;
  corrupt.data.resize(corrupt.data.size() / 3);  // cut off: does not decode
  std::fill(corrupt.data.begin() + 2, corrupt.data.end(), 0x5a);
  int injected = 0;
  double last_inject = -1;
  auto injectBadFrames = [&] {
    if (!inject || !ros::Time::isValid()) return;
    const double now = ros::Time::now().toSec();
    if (now - last_inject < 0.05) return;
    last_inject = now;
    sensor_msgs::CompressedImage& m = injected % 2 ? corrupt : wrong_size;
    m.header.stamp = ros::Time::now();
    bad_pub.publish(m);
    ++injected;
  };
  auto finalState = [&] {
    injectBadFrames();
    for (const auto& s : statuses)
      if (s.state == CalibrationStatus::STATE_DONE || s.state == CalibrationStatus::STATE_FAILED)
        return &s;
    return static_cast<const CalibrationStatus*>(nullptr);
  };
  ASSERT_TRUE(spinUntil([&] { return finalState() != nullptr; }, 280.0))
      << "the node neither finished nor failed; last status: "
      << (statuses.empty() ? "none" : statuses.back().phase + " " + statuses.back().text);
  const CalibrationStatus end = *finalState();
  std::cout << "status " << end.phase << " state " << int(end.state) << ": " << end.text << " "
            << end.failure_reason << "\n";

  // The wheels stand still after the end: the ground truth a second later.
  const double t_end = end.header.stamp.toSec();
  ASSERT_TRUE(spinUntil([&] { return truth && truth->header.stamp.toSec() > t_end + 1.0; }, 60.0));
  const nav_msgs::Odometry last = *truth;
  const double still = testParam<double>("still_speed");
  EXPECT_LT(std::abs(last.twist.twist.linear.x), still) << "the wheels still turn after the end";
  EXPECT_LT(std::abs(last.twist.twist.angular.z), 10 * still) << "the robot still turns";

  if (expect == "failed") {
    EXPECT_EQ(end.state, CalibrationStatus::STATE_FAILED) << end.text;
    // Underscores stand for spaces (rostest arguments cannot hold spaces).
    std::string want = testParam<std::string>("failure_contains");
    std::replace(want.begin(), want.end(), '_', ' ');
    EXPECT_NE(end.failure_reason.find(want), std::string::npos)
        << "the reason '" << end.failure_reason << "' does not say '" << want << "'";
    EXPECT_EQ(readFile(yaml.string()), earlier) << "a failed stage touched " << yaml;
    EXPECT_FALSE(fs::exists(yaml.string() + ".prev"));
    return;
  }

  ASSERT_EQ(end.state, CalibrationStatus::STATE_DONE) << end.failure_reason;
  if (inject) {
    double dropped = -1;
    for (size_t i = 0; i < end.figure_names.size(); ++i)
      if (end.figure_names[i] == "frames_dropped") dropped = end.figure_values[i];
    std::cout << "injected " << injected << " bad frames, the node dropped " << dropped << "\n";
    EXPECT_GT(injected, 20);
    EXPECT_GT(dropped, 0) << "bad frames reached the calibration unnoticed";
  }
  EXPECT_EQ(end.text, "wrote " + yaml.string());
  // The earlier file is kept beside the new one.
  EXPECT_EQ(readFile(yaml.string() + ".prev"), earlier);
  std::string camera_name;
  sensor_msgs::CameraInfo info;
  ASSERT_TRUE(camera_calibration_parsers::readCalibration(yaml.string(), camera_name, info))
      << "camera_calibration_parsers cannot read " << yaml;
  EXPECT_TRUE(fs::exists(yaml.parent_path() / (veh + "_views") / "views.yaml"));

  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const auto& t = robot.camera.truth;
  const double fx = info.K[0], fy = info.K[4], cx = info.K[2], cy = info.K[5], k1 = info.D.at(0);
  std::cout << "fx " << fx << " (true " << t.fx << ", " << 100 * (fx / t.fx - 1) << " %) fy " << fy
            << " (" << t.fy << ", " << 100 * (fy / t.fy - 1) << " %) cx " << cx << " (" << t.cx
            << ") cy " << cy << " (" << t.cy << ") k1 " << k1 << " ("
            << t.distortion_coefficients[0] << ")\n";
  const double focal = testParam<double>("focal_tolerance");
  EXPECT_NEAR(fx, t.fx, focal * t.fx);
  EXPECT_NEAR(fy, t.fy, focal * t.fy);
  const double pp = testParam<double>("principal_tolerance_px");
  EXPECT_NEAR(cx, t.cx, pp);
  EXPECT_NEAR(cy, t.cy, pp);
  EXPECT_NEAR(k1, t.distortion_coefficients[0], testParam<double>("k1_tolerance"));

  // The sweep's cost: the angle turned until the fit. Its length in sim time is printed only: at a
  // real-time factor of 5 it grows with the machine's load (65-74 s here, 98 s on a CI machine),
  // because the robot waits for each step's frames.
  double t_probe = NAN, t_swept = NAN;
  for (const auto& s : statuses) {
    if (std::isnan(t_probe) && s.phase == "camera/probe") t_probe = s.header.stamp.toSec();
    if (std::isnan(t_swept) && s.phase == "camera/calibrate") t_swept = s.header.stamp.toSec();
  }
  ASSERT_FALSE(std::isnan(t_probe) || std::isnan(t_swept)) << "no camera/probe or camera/calibrate";
  std::cout << "sweep " << t_swept - t_probe << " s of sim time, turned " << turned_rad
            << " rad\n";
  EXPECT_LE(turned_rad, testParam<double>("max_sweep_turn_rad"));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_camera_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
