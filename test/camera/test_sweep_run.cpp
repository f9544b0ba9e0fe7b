// camera::SweepRun's failure paths without a simulator: silent inputs, a dead wheel.
#include <gtest/gtest.h>

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
}

}  // namespace
