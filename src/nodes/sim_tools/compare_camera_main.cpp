// compare_camera: a validation tool of the simulator (never used by a calibration): prints a
// camera_info YAML written by a calibration next to the TRUE lens of the simulated robot.
//   rosrun autocal compare_camera --robot-config sim/config/robot.yaml --calibration FILE.yaml
// Prints one row per quantity (found, truth, error), then the projection difference over the
// whole image (sim/projection_difference.h); exit codes: doc/calibration_run.md
// "Exit codes"; doc/nodes/compare_camera.md.
#include <camera_calibration_parsers/parse.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/sim/config.h"
#include "autocal/sim/projection_difference.h"

namespace {

const char* kUsage =
    "usage: compare_camera --robot-config ROBOT.yaml --calibration CAMERA_INFO.yaml\n";

int run(int argc, char** argv) {
  std::string robot_path, calibration_path;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) throw autocal::UsageError(k + " needs a value");
    if (k == "--robot-config") {
      robot_path = argv[++i];
    } else if (k == "--calibration") {
      calibration_path = argv[++i];
    } else {
      throw autocal::UsageError("unknown option " + k);
    }
  }
  if (robot_path.empty() || calibration_path.empty())
    throw autocal::UsageError("--robot-config and --calibration are required");
  const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(robot_path);
  std::string name;
  sensor_msgs::CameraInfo info;
  if (!camera_calibration_parsers::readCalibration(calibration_path, name, info))
    throw autocal::InputError(calibration_path + ": not a camera_info YAML");
  const auto& t = robot.camera.truth;
  const auto& n = robot.camera.nominal;
  std::printf("%-4s %12s %12s %12s %10s %14s\n", "", "calibrated", "truth", "error", "error %",
              "camera_info");
  auto row = [](const char* what, double found, double truth, double nominal, bool relative) {
    const double err = found - truth;
    if (relative) {
      std::printf("%-4s %12.3f %12.3f %+12.3f %+9.3f%% %14.3f\n", what, found, truth, err,
                  100 * err / truth, nominal);
    } else {
      std::printf("%-4s %12.5f %12.5f %+12.5f %10s %14.5f\n", what, found, truth, err, "", nominal);
    }
  };
  row("fx", info.K[0], t.fx, n.fx, true);
  row("fy", info.K[4], t.fy, n.fy, true);
  row("cx", info.K[2], t.cx, n.cx, true);
  row("cy", info.K[5], t.cy, n.cy, true);
  static const char* kTerms[] = {"k1", "k2", "p1", "p2", "k3"};
  for (size_t i = 0; i < 5 && i < info.D.size() && i < t.distortion_coefficients.size(); ++i) {
    row(kTerms[i], info.D[i], t.distortion_coefficients[i],
        i < n.distortion_coefficients.size() ? n.distortion_coefficients[i] : NAN, false);
  }
  // Over the whole image, where the views' own reprojection error cannot look: the true lens's
  // ray of each pixel (every 8 px) projected with the calibrated model.
  const autocal::sim::ProjectionDifference d =
      autocal::sim::projectionDifference(t, autocal::loadCameraInfoYaml(calibration_path));
  std::printf(
      "projection difference over the whole image (%d pixels, every 8 px): RMS %.3f px, worst "
      "%.3f px; upper half %.3f px, lower half %.3f px, within 100 px of the centre %.3f px%s; "
      "worst at (%.0f, %.0f)\n",
      d.pixels, d.rms_px, d.worst_px, d.upper_rms_px, d.lower_rms_px, d.centre_rms_px,
      d.unmapped > 0 ? (", " + std::to_string(d.unmapped) + " pixels unmapped").c_str() : "",
      d.worst_u_px, d.worst_v_px);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "compare_camera", [&] { return run(argc, argv); }, kUsage);
}
