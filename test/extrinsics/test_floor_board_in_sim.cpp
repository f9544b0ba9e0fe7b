// Duckietown's board-on-the-floor extrinsics (extrinsics::calibrateFromFloorBoard) on frames the
// simulator renders, judged by the simulator's truth (support/floor_truth.h). Four mounts, each
// with every degree of freedom a real one has.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "autocal/errors.h"
#include "autocal/extrinsics/floor_board.h"
#include "autocal/sim/config.h"
#include "autocal/sim/floor_truth.h"
#include "autocal/sim/renderer.h"

namespace {

using namespace autocal;

const std::string kConfigDir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";

sim::RobotConfig mounted(double height_m, double pitch_rad, double roll_rad, double yaw_rad,
                         double x_m, double y_m) {
  sim::RobotConfig robot = sim::loadRobotConfig(kConfigDir + "robot_ideal.yaml");
  robot.camera.height_m = height_m;
  robot.camera.pitch_rad = pitch_rad;
  robot.camera.roll_rad = roll_rad;
  robot.camera.yaw_rad = yaw_rad;
  robot.camera.x_m = x_m;
  robot.camera.y_m = y_m;
  return robot;
}

cv::Mat renderStill(const sim::RobotConfig& robot, const sim::WorldConfig& world) {
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  sim::Renderer renderer(robot.camera, world, render);
  std::mt19937_64 rng(7);
  cv::Mat image = renderer.render({world.robot_start}, rng);
  if (const char* dir = std::getenv("AUTOCAL_DEBUG_DIR"))
    cv::imwrite(std::string(dir) + "/floor_board.png", image);
  return image;
}

class FloorBoardInSim : public ::testing::TestWithParam<int> {};

sim::RobotConfig mountNumber(int i) {
  switch (i) {
    case 0:
      return sim::loadRobotConfig(kConfigDir + "robot_ideal.yaml");
    case 1:
      return mounted(0.095, 0.33, 0.02, 0.03, 0.065, 0.008);
    case 2:
      return mounted(0.118, 0.21, -0.025, -0.04, 0.048, -0.012);
    default: {
      sim::RobotConfig r = mounted(0.105, 0.28, 0.015, -0.02, 0.06, 0.0);
      r.camera.truth.fx *= 0.92;  // a wider lens
      r.camera.truth.fy *= 0.92;
      return r;
    }
  }
}

TEST_P(FloorBoardInSim, GroundProjectionWithinAMillimetresOverTheFloorItSees) {
  const sim::RobotConfig robot = mountNumber(GetParam());
  const sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml");
  const extrinsics::CameraInfoRectification camera = sim::trueCameraInfo(robot);
  const extrinsics::FloorBoardResult r =
      extrinsics::calibrateFromFloorBoard(renderStill(robot, world), camera, {});
  const sim::FloorError e = sim::floorError(robot, camera.rectified, r.homography);
  const extrinsics::CameraMount& m = r.mount;
  const sim::CameraConfig& t = robot.camera;
  std::printf(
      "mount %d: floor %.2f mm RMS, %.2f mm worst over %d points; height %.2f mm (truth %.2f, "
      "sigma %.2f), pitch %.3f deg (%.3f), roll %.3f deg (%.3f), yaw %.3f deg (%.3f), x %.2f mm "
      "(%.2f), y %.2f mm (%.2f); board %.2f mm RMS, %.3f px\n",
      GetParam(), 1e3 * e.rms_m, 1e3 * e.max_m, e.points, 1e3 * m.height_m, 1e3 * t.height_m,
      1e3 * r.mount_sigma.height_m, m.pitch_rad * 180 / M_PI, t.pitch_rad * 180 / M_PI,
      m.roll_rad * 180 / M_PI, t.roll_rad * 180 / M_PI, m.yaw_rad * 180 / M_PI,
      t.yaw_rad * 180 / M_PI, 1e3 * m.x_m, 1e3 * t.x_m, 1e3 * m.y_m, 1e3 * t.y_m,
      1e3 * r.board_rms_m, r.reprojection_rms_px);
  EXPECT_GT(e.points, 100);
  EXPECT_LE(e.rms_m, 0.005);
  EXPECT_LE(e.max_m, 0.01);
  const double deg = M_PI / 180;
  EXPECT_NEAR(m.height_m, t.height_m, 0.002);
  EXPECT_NEAR(m.pitch_rad, t.pitch_rad, 0.3 * deg);
  EXPECT_NEAR(m.roll_rad, t.roll_rad, 0.3 * deg);
  EXPECT_NEAR(m.yaw_rad, t.yaw_rad, 0.5 * deg);
  EXPECT_NEAR(m.x_m, t.x_m, 0.005);
  EXPECT_NEAR(m.y_m, t.y_m, 0.005);
}

INSTANTIATE_TEST_SUITE_P(FourMounts, FloorBoardInSim, ::testing::Values(0, 1, 2, 3));

/// Where a lane line's edge crosses an image row of the rectified image: the sub-pixel column where
/// `channel` passes `level` going right from `from_u` (rising or falling as asked); NaN if never.
double edgeInRow(const cv::Mat& bgr, int v, int channel, double level, int from_u, bool rising) {
  for (int u = std::max(1, from_u); u < bgr.cols; ++u) {
    const double a = bgr.at<cv::Vec3b>(v, u - 1)[channel], b = bgr.at<cv::Vec3b>(v, u)[channel];
    if (rising ? (a < level && b >= level) : (a >= level && b < level))
      return u - 1 + (level - a) / (b - a);  // pixel centres at integers
  }
  return std::nan("");
}

// As Duckietown uses the file: a frame rectified with P, its lane lines' edges found in it and
// projected with the homography land where the world YAML puts them (the white line's inner edge
// at y = -0.115 m, the yellow line's at +0.115 m), from 0.4 m to 0.8 m ahead.
TEST(FloorBoardInSim, LaneLinesLandWhereTheWorldPutsThem) {
  const sim::RobotConfig robot = mountNumber(1);
  const sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml");
  const extrinsics::CameraInfoRectification camera = sim::trueCameraInfo(robot);
  const cv::Mat raw = renderStill(robot, world);
  const extrinsics::FloorBoardResult r = extrinsics::calibrateFromFloorBoard(raw, camera, {});
  const cv::Mat rectified = extrinsics::rectifyImage(raw, camera);
  const double white_inner = world.lane_lines[0].y0_m + 0.5 * world.lane_lines[0].width_m;
  const double yellow_inner = world.lane_lines[1].y0_m - 0.5 * world.lane_lines[1].width_m;
  int white = 0, yellow = 0;
  double worst = 0;
  for (int v = 0; v < rectified.rows; v += 2) {
    const Eigen::Vector2d centre =
        extrinsics::pixelToGround(r.homography, {0.5 * rectified.cols, static_cast<double>(v)});
    if (!(centre.x() > 0.42 && centre.x() < 0.8)) continue;
    // The white line right of the image's centre: its inner (left) edge rises in blue.
    const double uw = edgeInRow(rectified, v, 0, 160, rectified.cols / 2, true);
    if (std::isfinite(uw)) {
      const Eigen::Vector2d g = extrinsics::pixelToGround(r.homography, {uw, double(v)});
      worst = std::max(worst, std::abs(g.y() - white_inner));
      EXPECT_NEAR(g.y(), white_inner, 0.01) << "white line at x " << g.x();
      ++white;
    }
    // The yellow line left of the centre: going left to right, its inner (right) edge is where red
    // falls back to the floor's.
    const double uy = edgeInRow(rectified, v, 2, 160, 0, false);
    if (std::isfinite(uy) && uy < 0.5 * rectified.cols) {
      const Eigen::Vector2d g = extrinsics::pixelToGround(r.homography, {uy, double(v)});
      if (g.y() > 0.05) {
        worst = std::max(worst, std::abs(g.y() - yellow_inner));
        EXPECT_NEAR(g.y(), yellow_inner, 0.01) << "yellow line at x " << g.x();
        ++yellow;
      }
    }
  }
  std::printf("lane edges: %d white, %d yellow rows, worst %.2f mm off\n", white, yellow,
              1e3 * worst);
  EXPECT_GT(white, 10);
  EXPECT_GT(yellow, 5);
}

TEST(FloorBoardInSimFails, NoBoardInView) {
  const sim::RobotConfig robot = mountNumber(0);
  sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml");
  world.floor_boards.front().pose.x_m = -1.0;  // behind the robot
  try {
    extrinsics::calibrateFromFloorBoard(renderStill(robot, world), sim::trueCameraInfo(robot), {});
    FAIL() << "no error";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
  }
}

TEST(FloorBoardInSimFails, OffsetsThatPutTheCameraWhereNoDuckiebotHasIt) {
  const sim::RobotConfig robot = mountNumber(0);
  const sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml");
  extrinsics::FloorBoardOptions o;
  o.board.offset_x_m = 0.55;  // the board said to lie 0.36 m further out than it does
  try {
    extrinsics::calibrateFromFloorBoard(renderStill(robot, world), sim::trueCameraInfo(robot), o);
    FAIL() << "no error";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("no Duckiebot can have"), std::string::npos) << e.what();
  }
}

}  // namespace
