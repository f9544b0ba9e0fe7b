// WheelRun as a Stage: its status and the files it writes at its end (the kinematics, and the
// camera's extrinsics with their ground view when the mount was measured).
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/extrinsics/floor_board.h"
#include "autocal/extrinsics/ground_projection.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/wheels/wheel_run.h"

namespace autocal {
namespace wheels {

bool WheelRun::addFrame(double stamp_s, const cv::Mat& image, const std::string& /*source*/) {
  if (!wantsFrame(stamp_s)) return false;
  addFrame(stamp_s, image);
  if (stage_ == WheelRunStage::kExtrinsics) image.copyTo(ground_frame_);
  return true;
}

StageStatus WheelRun::status() const {
  const auto& h = estimator_.history();
  StageStatus s;
  s.step = name(stage_);
  s.key = std::to_string(h.size());
  s.progress = progress();
  s.text = describe();
  s.figures = {{"iteration", static_cast<double>(h.size())},
               {"k", estimator_.ratio()},
               {"trim", result().trim},
               {"last_dtheta_rad", h.empty() ? 0.0 : h.back().delta_theta_rad},
               {"heading_rad", std::isfinite(last_heading_rad_) ? last_heading_rad_ : 0.0},
               {"elapsed_s", elapsedS()}};
  return s;
}

namespace {

/// Writes the extrinsics file (and its ground view over `ground_frame` when there is one); its
/// DONE figures.
Figures writeExtrinsics(const std::string& path, const extrinsics::TagMountResult& x, int passes,
                        double hop_speed_mps, const std::string& intrinsics_file,
                        const cv::Mat& ground_frame, std::string* log) {
  const extrinsics::CameraInfoRectification camera = extrinsics::loadRectification(intrinsics_file);
  const extrinsics::CameraMount& m = x.mount;
  const Eigen::Matrix3d H = extrinsics::homographyFromMount(m, camera.rectified);
  writeFileAtomically(path,
                      extrinsics::extrinsicsYaml(
                          H, m, x.has_sigma ? &x.sigma : nullptr,
                          {{"plane_rms_m", x.plane_rms_m},
                           {"rejected_sightings", static_cast<double>(x.rejected)},
                           {"turn_centre_rms_m", x.centre_rms_m},
                           {"yaw_spread_rad", x.yaw_spread_rad},
                           {"drives", static_cast<double>(x.straight)},
                           {"passes", static_cast<double>(passes)},
                           {"turns", static_cast<double>(x.spins)},
                           // For the odometry stage, which finds how the hops turned.
                           {extrinsics::kYawPerTurnKey, x.yaw_per_turn_per_m},
                           {extrinsics::kStraightSpeedKey, hop_speed_mps}},
                          camera.rectified,
                          "the floor tags of the wheel stage (intrinsics " + intrinsics_file + ")",
                          utcNowIso8601()));
  if (!ground_frame.empty()) {
    // For a person to check: the floor grid where the homography puts it, over the last still.
    cv::Mat view = extrinsics::rectifyImage(ground_frame, camera);
    if (view.channels() == 1) cv::cvtColor(view, view, cv::COLOR_GRAY2BGR);
    extrinsics::drawFloorGrid(view, H);
    writePngAtomically(extrinsics::groundViewPath(path), view);
  }
  *log = "; wrote " + path + ": camera " + formatNumber(1e3 * m.height_m, 4) + " mm high, pitch " +
         formatNumber(m.pitch_rad * 180 / M_PI, 3) + " deg, roll " +
         formatNumber(m.roll_rad * 180 / M_PI, 3) + " deg, yaw " +
         formatNumber(m.yaw_rad * 180 / M_PI, 3) + " deg, " + formatNumber(1e3 * m.x_m, 4) +
         " mm ahead of the axle, " + formatNumber(1e3 * m.y_m, 4) + " mm left (" +
         std::to_string(x.straight) + " drives in " + std::to_string(passes) + " passes, " +
         std::to_string(x.spins) + " turns)";
  return {{"extrinsics_written", 1.0},
          {"camera_height_m", m.height_m},
          {"camera_pitch_rad", m.pitch_rad},
          {"camera_roll_rad", m.roll_rad},
          {"camera_yaw_rad", m.yaw_rad},
          {"camera_x_m", m.x_m},
          {"camera_y_m", m.y_m},
          {"extrinsics_passes", static_cast<double>(passes)}};
}

}  // namespace

StageResult WheelRun::finish(const StageOutput& output) {
  const KinematicsParams k = result();
  StageResult r;
  r.file = kinematicsPath(output.calibration_root, output.veh);
  writeKinematicsFile(r.file, k);  // validates first; throws on failure
  const auto& h = estimator_.history();
  r.figures = {{"trim", k.trim},
               {"trim_before", options_.kinematics.trim},
               {"k", estimator_.ratio()},
               {"deadband_left", k.deadband_left},
               {"deadband_right", k.deadband_right},
               {"drives", static_cast<double>(h.size())},
               {"last_dtheta_rad", h.empty() ? 0.0 : h.back().delta_theta_rad},
               {"elapsed_s", elapsedS()}};
  r.log = "trim " + formatNumber(k.trim, 4) + " (was " + formatNumber(options_.kinematics.trim, 4) +
          "), k " + formatNumber(estimator_.ratio(), 6) + ", deadband " +
          formatNumber(k.deadband_left, 4) + "/" + formatNumber(k.deadband_right, 4) + ", " +
          std::to_string(h.size()) + " drives, " + formatNumber(elapsedS(), 4) + " s";
  if (options_.extrinsics_spins == 0) return r;
  if (const extrinsics::TagMountResult* x = extrinsicsResult()) {
    std::string log;
    const Figures f = writeExtrinsics(
        extrinsics::extrinsicsPath(output.calibration_root, output.veh), *x, extrinsics_pass_ + 1,
        options_.drive_speed_mps, options_.intrinsics_file, ground_frame_, &log);
    r.figures.insert(r.figures.end(), f.begin(), f.end());
    r.log += log;
  } else {
    // The trim is right all the same: the stage succeeds, without the extrinsics file, and its
    // DONE says why they are missing.
    r.figures.emplace_back("extrinsics_written", 0.0);
    r.text = "wrote " + r.file + "; no camera extrinsics: " + extrinsics_failure_;
    r.log += "; no camera extrinsics written: " + extrinsics_failure_;
  }
  return r;
}

}  // namespace wheels
}  // namespace autocal
