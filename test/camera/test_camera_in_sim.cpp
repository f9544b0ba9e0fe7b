// The camera calibration core on the simulator's rendered frames: the robot pivots on each wheel
// in front of the default world's boards (paper 000 §4: the robot turns in place past boards set
// around it), every still frame goes through the ViewCollector as a live frame would, and the
// intrinsics are compared with the simulator's TRUE lens (which the calibration never reads).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "autocal/camera/calibration.h"
#include "autocal/camera/view_selection.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"

namespace {

using namespace autocal;

TEST(CameraInSim, PivotingPastTheBoardsRecoversTheTrueIntrinsics) {
  const std::string dir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";
  const sim::RobotConfig robot = sim::loadRobotConfig(dir + "robot_ideal.yaml");
  const sim::WorldConfig world = sim::loadWorldConfig(dir + "world.yaml");
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  sim::Renderer renderer(robot.camera, world, render);

  const sim::ChessboardConfig& board = world.chessboards.front();
  camera::BoardSpec spec;
  spec.inner_corners = cv::Size(board.cols, board.rows);
  spec.square_size_m = board.square_m;
  camera::ChessboardDetectorOptions detector;
  detector.half_resolution_precheck = false;  // the robot's boards are small in its image
  camera::ViewCollector collector(spec, detector, camera::ViewSelectionOptions());

  // Pivot on the stopped left wheel, then on the stopped right wheel, from two places.
  std::mt19937_64 rng(11);
  int frames = 0;
  for (const double start_x : {0.0, -0.12}) {
    for (const sim::Side stopped : {sim::Side::kLeft, sim::Side::kRight}) {
      for (int i = 0; i < 24; ++i) {
        const sim::Pose2 pose = sim::pivotPose({start_x, 0, 0}, robot.wheelbase, stopped, -1.6 + 3.2 * i / 23.0);
        collector.addFrame(renderer.render({pose}, rng), "frame " + std::to_string(frames++));
      }
    }
  }
  std::vector<std::vector<cv::Point2f>> views;
  for (const camera::CalibrationView& v : collector.views()) views.push_back(v.corners);
  std::cout << frames << " frames, " << views.size() << " views kept\n";
  ASSERT_GE(views.size(), 8u);

  const camera::CalibrationResult r =
      camera::calibrate(views, collector.imageSize(), spec, camera::CalibrationOptions());
  const sim::Intrinsics& truth = robot.camera.truth;
  std::cout << "fx " << r.intrinsics.fx << " (true " << truth.fx << "), fy " << r.intrinsics.fy << " ("
            << truth.fy << "), cx " << r.intrinsics.cx << " (" << truth.cx << "), cy " << r.intrinsics.cy << " ("
            << truth.cy << "), k1 " << r.intrinsics.distortion_coefficients[0] << " (" << truth.distortion_coefficients[0]
            << "), k2 " << r.intrinsics.distortion_coefficients[1] << " (" << truth.distortion_coefficients[1] << "), rms "
            << r.rms_px << " px, " << r.fitted_terms << "\n";
  EXPECT_NEAR(r.intrinsics.fx, truth.fx, 0.01 * truth.fx);
  EXPECT_NEAR(r.intrinsics.fy, truth.fy, 0.01 * truth.fy);
  EXPECT_NEAR(r.intrinsics.cx, truth.cx, 4.0);
  EXPECT_NEAR(r.intrinsics.cy, truth.cy, 4.0);
  EXPECT_NEAR(r.intrinsics.distortion_coefficients[0], truth.distortion_coefficients[0], 0.03);
  EXPECT_LT(r.rms_px, 0.5);
  // The nominal model camera_info starts from is far off: the calibration is what brings it in.
  EXPECT_GT(std::abs(robot.camera.nominal.fx - truth.fx), 0.03 * truth.fx);
}

}  // namespace
