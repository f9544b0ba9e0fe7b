// camera::SweepRun's failure paths without a simulator: silent inputs, a dead wheel; the targets
// of more views where the projection is least sure.
#include <gtest/gtest.h>
#include <cmath>

#include "autocal/camera/sweep_run.h"
#include "autocal/errors.h"

namespace {

using namespace autocal;
using namespace autocal::camera;

CameraCalibrationConfig config() {
  CameraCalibrationConfig c = loadCameraCalibrationConfig(std::string(AUTOCAL_SOURCE_DIR) +
                                                          "/config/camera_calibration.yaml");
  return c;
}

/// Runs `run` for `seconds` at 100 Hz, frames at 30 Hz while `camera_on(t)`, encoders at 30 Hz
/// while `encoders_on(t)` (never moving: a dead wheel). Returns the failure, or "" at the end.
template <typename Camera, typename Encoders>
std::string drive(SweepRun& run, double seconds, Camera camera_on, Encoders encoders_on) {
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  try {
    for (int i = 0; i < seconds * 100; ++i) {
      const double t = i * 0.01;
      if (i % 3 == 0 && encoders_on(t)) run.addEncoders(t, 100, 200, 135, t);
      if (i % 3 == 0 && camera_on(t)) {
        run.noteFrameArrived(t);
        if (run.wantsFrame(t)) run.addFrame(t, grey, "grey");
      }
      run.update(t);
    }
  } catch (const CalibrationError& e) {
    return e.what();
  }
  return "";
}

TEST(SweepRun, NoCameraAtAllFails) {
  SweepRun run(SweepRunOptions(), config());
  const std::string failure = drive(
      run, 20, [](double) { return false; }, [](double) { return true; });
  EXPECT_NE(failure.find("no camera frame in 5 s"), std::string::npos) << failure;
  EXPECT_EQ(run.stage(), SweepRunStage::kFailed);
}

TEST(SweepRun, NoEncodersAtAllFails) {
  SweepRun run(SweepRunOptions(), config());
  const std::string failure = drive(
      run, 20, [](double) { return true; }, [](double) { return false; });
  EXPECT_NE(failure.find("no encoder reading"), std::string::npos) << failure;
}

TEST(SweepRun, CameraFallingSilentFails) {
  SweepRun run(SweepRunOptions(), config());
  const std::string failure = drive(
      run, 30, [](double t) { return t < 3; }, [](double) { return true; });
  EXPECT_NE(failure.find("camera has been silent"), std::string::npos) << failure;
}

TEST(SweepRun, EncodersFallingSilentFail) {
  SweepRun run(SweepRunOptions(), config());
  const std::string failure = drive(
      run, 30, [](double) { return true; }, [](double t) { return t < 3; });
  EXPECT_NE(failure.find("encoders have been silent"), std::string::npos) << failure;
}

TEST(SweepRun, AWheelThatNeverMovesFailsTheProbeAndCommandsOneWheelOnly) {
  SweepRun run(SweepRunOptions(), config());
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  std::string failure;
  double max_duty = 0;
  try {
    for (int i = 0; i < 60000; ++i) {
      const double t = i * 0.01;
      if (i % 3 == 0) {
        run.addEncoders(t, 0, 0, 135, t);
        run.noteFrameArrived(t);
      }
      const WheelDuties d = run.update(t);
      // Pivoting: one wheel at a time, never both.
      EXPECT_TRUE(d.left == 0 || d.right == 0) << d.left << " " << d.right;
      max_duty = std::max({max_duty, std::abs(d.left), std::abs(d.right)});
    }
  } catch (const CalibrationError& e) {
    failure = e.what();
  }
  EXPECT_NE(failure.find("did not move forward up to duty 0.40"), std::string::npos) << failure;
  EXPECT_LE(max_duty, SweepRunOptions().probe.max_duty + 1e-9);
  EXPECT_EQ(run.update(1e6).left, 0.0) << "a failed run commands nothing";
}

TEST(SweepRun, FramesThatArriveButAreAllDroppedFail) {
  // The node drops every frame (undecodable, another size): they arrive, none is processed.
  SweepRunOptions o;
  o.probe_min_duty = false;
  SweepRun run(o, config());
  std::string failure;
  try {
    for (int i = 0; i < 3000; ++i) {
      const double t = i * 0.01;
      if (i % 3 == 0) {
        run.addEncoders(t, 0, 0, 135, t);
        run.noteFrameArrived(t);
      }
      run.update(t);
    }
  } catch (const CalibrationError& e) {
    failure = e.what();
  }
  EXPECT_NE(failure.find("no usable camera frame"), std::string::npos) << failure;
}

TEST(SweepRunOptions, ValidateNamesTheBadKey) {
  SweepRunOptions o;
  o.max_step_duty = 1.5;
  try {
    o.validate();
    FAIL() << "accepted max_step_duty 1.5";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_step_duty"), std::string::npos) << e.what();
  }
  o = SweepRunOptions();
  o.refine_tolerance_rad = 0;
  EXPECT_THROW(o.validate(), ConfigError);
}

/// A pinhole camera, 640 x 480, f 300; a view at heading 0.5 of three corners, one high and two
/// low, and one at heading -0.3 of one low corner.
struct TargetScene {
  CameraIntrinsics fit;
  std::vector<CalibrationView> views;
  std::map<int, double> heading_by_frame;
  ProjectionUncertainty uncertainty;
  TargetScene() {
    fit.fx = fit.fy = 300;
    fit.cx = 320;
    fit.cy = 240;
    fit.distortion_coefficients = {0, 0, 0, 0, 0};
    CalibrationView v;
    v.corners = {{330, 60}, {420, 400}, {600, 420}};
    v.frame_index = 4;
    views.push_back(v);
    heading_by_frame[4] = 0.5;
    v.corners = {{600, 420}};
    v.frame_index = 7;
    views.push_back(v);
    heading_by_frame[7] = -0.3;
    // Even, except one cell in the lower left and one in the upper right.
    uncertainty.valid = true;
    uncertainty.grid = {16, 12};
    uncertainty.sigma_px.assign(16 * 12, 0.1);
    uncertainty.sigma_px[10 * 16 + 0] = 3.0;  // centre (20, 420)
    uncertainty.sigma_px[1 * 16 + 15] = 2.0;  // centre (620, 60)
  }
};

/// Elevation of a pixel of TargetScene's camera [rad].
double elevation(double u, double v) {
  return std::atan2(-(v - 240) / 300, std::hypot((u - 320) / 300, 1.0));
}

TEST(ViewTargets, TurnsACornerOfTheCellsElevationOntoTheLeastSureCellOfEachHalf) {
  const TargetScene s;
  const std::vector<ViewTarget> t =
      viewTargets(s.uncertainty, s.fit, s.views, s.heading_by_frame, 0.5);
  ASSERT_EQ(t.size(), 2u);
  // Left half: the cell at (20, 420). Of the corners, (600, 420) has the elevation nearest its
  // own (a row's elevation falls toward the image's sides), seen at headings 0.5 and -0.3; from
  // 0.5 the one seen there needs the smaller turn. Counter-clockwise moves the scene right: the
  // heading falls by the azimuth from the cell to the corner.
  EXPECT_NEAR(t[0].pixel.x, 20, 1e-9);
  EXPECT_NEAR(t[0].pixel.y, 420, 1e-9);
  EXPECT_DOUBLE_EQ(t[0].need, 3.0);
  EXPECT_EQ(t[0].frame_index, 4);
  EXPECT_NEAR(t[0].corner_px.x, 600, 1e-4);
  EXPECT_NEAR(t[0].heading_rad, 0.5 + std::atan(-300.0 / 300) - std::atan(280.0 / 300), 1e-6);
  EXPECT_NEAR(t[0].elevation_miss_rad, std::abs(elevation(600, 420) - elevation(20, 420)), 1e-6);
  // From heading -2 the view at -0.3 is nearer.
  const std::vector<ViewTarget> from_right =
      viewTargets(s.uncertainty, s.fit, s.views, s.heading_by_frame, -2.0);
  ASSERT_EQ(from_right.size(), 2u);
  EXPECT_EQ(from_right[0].frame_index, 7);
  EXPECT_NEAR(from_right[0].heading_rad, -0.3 + std::atan(-300.0 / 300) - std::atan(280.0 / 300),
              1e-6);
  // Right half: the cell at (620, 60), reached by the high corner.
  EXPECT_NEAR(t[1].pixel.x, 620, 1e-9);
  EXPECT_NEAR(t[1].corner_px.y, 60, 1e-4);
  EXPECT_NEAR(t[1].heading_rad, 0.5 + std::atan(300.0 / 300) - std::atan(10.0 / 300), 1e-6);

  // Without an uncertainty, the cells farthest from every corner seen.
  ProjectionUncertainty none;
  const std::vector<ViewTarget> far = viewTargets(none, s.fit, s.views, s.heading_by_frame, 0.5);
  ASSERT_EQ(far.size(), 2u);
  EXPECT_NEAR(far[0].pixel.x, 20, 1e-9);   // the left edge, far from the corners at x >= 330
  EXPECT_GT(far[0].need, 300);

  // No heading known for the view: nothing to turn to.
  EXPECT_TRUE(viewTargets(s.uncertainty, s.fit, s.views, {}, 0.5).empty());
}

}  // namespace
