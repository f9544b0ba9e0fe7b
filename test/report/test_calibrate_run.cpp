// The whole run (calibrate_run.test): waits for run_report_node's summary.yaml and judges the
// files it names against the simulator's truth (the robot config): the camera's fx, fy, cx, cy
// within 0.5 %, the trim within 0.005 of what the true wheels need, and UAH's Ed within 0.2 %, the
// wheelbase and each wheel's distance per pulse within 0.5 %.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/sim/config.h"
#include "autocal/sim/floor_truth.h"
#include "autocal/sim/projection_difference.h"
#include "autocal/wheels/kinematics.h"
#include "support/ros_wait.h"
#include "support/test_params.h"
#include "support/wheels_in_sim.h"

namespace {

namespace fs = std::filesystem;
using autocal::YamlMap;
using autocal::test::spinUntil;
using autocal::test::testParam;

void expectWithin(const char* what, double found, double truth, double share) {
  std::cout << what << ": found " << found << ", truth " << truth << ", error "
            << 100 * (found - truth) / truth << " %" << std::endl;
  EXPECT_NEAR(found, truth, share * std::abs(truth)) << what;
}

TEST(CalibrateRun, EveryStageDoneAndTheFilesMatchTheTruth) {
  const std::string veh = testParam<std::string>("veh");
  const fs::path root = testParam<std::string>("calibration_root");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  const fs::path summary_path = root / "report" / veh / "summary.yaml";
  // An earlier test run's files (the nodes write their files only at their ends).
  ASSERT_TRUE(autocal::test::removeTree(root));
  ros::NodeHandle nh;
  // Where the robot truly was when the run ended: said with a failure (a stage that stalled or
  // met an obstacle).
  nav_msgs::Odometry last_pose;
  ros::Subscriber truth_sub = ros::NodeHandle(veh).subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100, [&](const nav_msgs::Odometry::ConstPtr& m) { last_pose = *m; });
  ASSERT_TRUE(spinUntil([&] { return fs::exists(summary_path); }, 580.0)) << summary_path;
  YamlMap summary = YamlMap::loadFile(summary_path.string());
  const auto& q = last_pose.pose.pose.orientation;
  ASSERT_EQ(summary.required<std::string>("result"), "success")
      << summary.required<std::string>("failure") << "; the robot's true pose at the end: x "
      << last_pose.pose.pose.position.x << " m, y " << last_pose.pose.pose.position.y
      << " m, yaw " << 2 * std::atan2(q.z, q.w) * 180 / M_PI << " deg (sim time "
      << last_pose.header.stamp.toSec() << " s)";
  EXPECT_TRUE(fs::exists(root / "report" / veh / "report.png"));
  YamlMap stages = summary.map("stages");

  // Camera: the file camera_info_manager reads.
  YamlMap camera = YamlMap::loadFile(stages.map("camera").required<std::string>("file"));
  const std::vector<double> k = camera.map("camera_matrix").required<std::vector<double>>("data");
  ASSERT_EQ(k.size(), 9u);
  expectWithin("fx", k[0], robot.camera.truth.fx, 0.005);
  expectWithin("fy", k[4], robot.camera.truth.fy, 0.005);
  expectWithin("cx", k[2], robot.camera.truth.cx, 0.005);
  expectWithin("cy", k[5], robot.camera.truth.cy, 0.005);
  // Over the whole image, not only where the boards were: the true lens's rays projected with the
  // calibrated model. The accuracy asked of a fleet's plumb_bob lens, and of a lens that is not
  // plumb_bob (the realistic robot's fisheye) with the model the stage chose.
  const autocal::sim::ProjectionDifference whole = autocal::sim::projectionDifference(
      robot.camera.truth,
      autocal::loadCameraInfoYaml(stages.map("camera").required<std::string>("file")));
  std::cout << "projection difference: RMS " << whole.rms_px << " px, worst " << whole.worst_px
            << " px; upper half " << whole.upper_rms_px << ", lower half " << whole.lower_rms_px
            << ", centre " << whole.centre_rms_px << " px" << std::endl;
  EXPECT_EQ(whole.unmapped, 0);
  if (robot.camera.truth.distortion_model == autocal::DistortionModel::kPlumbBob) {
    EXPECT_LE(whole.rms_px, 0.25);
    EXPECT_LE(whole.worst_px, 0.6);
  } else {
    EXPECT_LE(whole.rms_px, 0.5);
  }

  // Wheels: the trim the true wheels need with the deadband compensated (compare_wheels).
  const autocal::wheels::KinematicsParams kin =
      autocal::wheels::readKinematicsFile(stages.map("wheels").required<std::string>("file"));
  const double k_true = (robot.motor_gain_left * robot.wheel_radius_left) /
                        (robot.motor_gain_right * robot.wheel_radius_right);
  const double trim_true = autocal::wheels::trimFromSpeedRatio(k_true, kin.gain);
  std::cout << "trim: found " << kin.trim << ", truth " << trim_true << std::endl;
  EXPECT_NEAR(kin.trim, trim_true, 0.01);
  for (const auto& d : autocal::test::straightDrifts(robot, kin)) {
    std::cout << "drift over 2 m at " << d.speed_mps << " m/s: " << d.drift_m << " m" << std::endl;
    EXPECT_LE(d.drift_m, d.bound_m) << " at " << d.speed_mps << " m/s";
  }

  // Extrinsics: the wheel stage's camera mount as a ground homography for the camera stage's P;
  // each floor point's true pixel rectified with the calibrated camera and projected.
  const fs::path extrinsic = root / "camera_extrinsic" / (veh + ".yaml");
  // In robot mode (lost frames, late messages) the stage may not determine the mount: it then
  // says why in its DONE text and writes no file, which ~extrinsics_required false accepts.
  const std::string wheels_text = stages.map("wheels").required<std::string>("text");
  if (!fs::exists(extrinsic) && !testParam<bool>("extrinsics_required")) {
    std::cout << "no camera extrinsics written (accepted: ~extrinsics_required false): "
              << wheels_text << std::endl;
    EXPECT_NE(wheels_text.find("no camera extrinsics: "), std::string::npos) << wheels_text;
  } else {
    EXPECT_EQ(wheels_text.find("no camera extrinsics"), std::string::npos) << wheels_text;
    ASSERT_TRUE(fs::exists(extrinsic)) << extrinsic;
    const autocal::sim::FloorError floor = autocal::sim::floorErrorThroughCalibration(
        robot,
        autocal::extrinsics::loadRectification(stages.map("camera").required<std::string>("file")),
        autocal::extrinsics::readHomography(extrinsic.string()));
    std::cout << "ground projection: " << 1e3 * floor.rms_m << " mm RMS, " << 1e3 * floor.max_m
              << " mm worst over " << floor.points << " floor points" << std::endl;
    EXPECT_LE(floor.rms_m, 0.01);
    EXPECT_LE(floor.max_m, 0.02);
    // The pose it comes from, against the simulator's true mount.
    YamlMap pose = YamlMap::loadFile(extrinsic.string()).map("camera_pose");
    const autocal::sim::CameraConfig& mount = robot.camera;
    const double deg = M_PI / 180;
    EXPECT_NEAR(pose.required<double>("height_m"), mount.height_m, 0.002);
    EXPECT_NEAR(pose.required<double>("pitch_rad"), mount.pitch_rad, 0.3 * deg);
    EXPECT_NEAR(pose.required<double>("roll_rad"), mount.roll_rad, 0.3 * deg);
    EXPECT_NEAR(pose.required<double>("yaw_rad"), mount.yaw_rad, 0.5 * deg);
    // The ground view beside it (the report shows it): the rectified frame with the grid.
    const cv::Mat ground =
        cv::imread(autocal::extrinsics::groundViewPath(extrinsic.string()), cv::IMREAD_COLOR);
    EXPECT_EQ(ground.cols, robot.camera.truth.width);
    EXPECT_EQ(ground.rows, robot.camera.truth.height);
  }

  // The report's believed path (the encoders, dead-reckoned) against the simulator's true path
  // it draws beside it: the same length, and ends close (a robot's dead reckoning drifts, but
  // not across the room).
  const std::vector<double> believed =
      summary.map("believed_path").required<std::vector<double>>("end");
  const std::vector<double> truth = summary.map("true_path").required<std::vector<double>>("end");
  ASSERT_EQ(believed.size(), 3u);
  ASSERT_EQ(truth.size(), 3u);
  const double believed_m = summary.map("believed_path").required<double>("length_m");
  const double true_m = summary.map("true_path").required<double>("length_m");
  const double apart_m = std::hypot(believed[0] - truth[0], believed[1] - truth[1]);
  const double off_m = summary.map("true_path").required<double>("believed_off_m");
  std::cout << "believed path " << believed_m << " m, true " << true_m << " m; the ends " << apart_m
            << " m apart, at most " << off_m << " m apart on the way" << std::endl;
  EXPECT_NEAR(believed_m, true_m, 0.05 * true_m);
  EXPECT_LE(apart_m, 0.05 * true_m);

  if (!testParam<bool>("odometry")) {
    EXPECT_FALSE(stages.has("odometry"));
    return;
  }
  // With the odometry stage's wheels the believed path follows the true one all the way (with one
  // nominal radius, wheels of different diameters bend each straight drive: over a metre off here).
  EXPECT_LE(off_m, 0.02 * true_m);
  // Odometry (UAH): Ed = r_R/r_L, the wheelbase, each wheel's distance per pulse.
  YamlMap odo = YamlMap::loadFile(stages.map("odometry").required<std::string>("file"));
  EXPECT_EQ(odo.required<std::string>("method"), "uah");
  expectWithin("Ed", odo.required<double>("Ed"), robot.wheel_radius_right / robot.wheel_radius_left,
               0.002);
  expectWithin("wheelbase", odo.required<double>("b"), robot.wheelbase, 0.005);
  const double pulse = 2 * M_PI / robot.encoder_resolution;
  expectWithin("left m/pulse", odo.required<double>("left_m_per_pulse"),
               pulse * robot.wheel_radius_left, 0.005);
  expectWithin("right m/pulse", odo.required<double>("right_m_per_pulse"),
               pulse * robot.wheel_radius_right, 0.005);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibrate_run");
  return RUN_ALL_TESTS();
}
