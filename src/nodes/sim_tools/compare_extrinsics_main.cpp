// compare_extrinsics: a validation tool of the simulator (never used by a calibration): prints a
// camera_extrinsic file next to the simulated robot's TRUE camera mount, and how far its
// homography puts the floor the camera sees (0.1-0.6 m ahead) from where it is.
//   rosrun autocal compare_extrinsics --robot-config sim/config/robot.yaml
//       --calibration camera_extrinsic/VEH.yaml --camera-info camera_intrinsic/VEH.yaml
// Each floor point's true pixel (the true lens) is rectified with --camera-info, as Duckietown
// rectifies a frame, and projected with the file's homography (sim::floorErrorThroughCalibration).
// Exit codes: doc/calibration_run.md "Exit codes"; doc/nodes/compare_extrinsics.md.
#include <cmath>
#include <cstdio>
#include <string>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/sim/config.h"
#include "autocal/sim/floor_truth.h"

namespace {

const char* kUsage =
    "usage: compare_extrinsics --robot-config ROBOT.yaml --calibration EXTRINSICS.yaml "
    "--camera-info INTRINSICS.yaml\n";

int run(int argc, char** argv) {
  std::string robot_path, calibration_path, info_path;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) throw autocal::UsageError(k + " needs a value");
    if (k == "--robot-config") {
      robot_path = argv[++i];
    } else if (k == "--calibration") {
      calibration_path = argv[++i];
    } else if (k == "--camera-info") {
      info_path = argv[++i];
    } else {
      throw autocal::UsageError("unknown option " + k);
    }
  }
  if (robot_path.empty() || calibration_path.empty() || info_path.empty())
    throw autocal::UsageError("--robot-config, --calibration and --camera-info are required");
  const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(robot_path);
  const Eigen::Matrix3d H = autocal::extrinsics::readHomography(calibration_path);
  const autocal::sim::FloorError e = autocal::sim::floorErrorThroughCalibration(
      robot, autocal::extrinsics::loadRectification(info_path), H);
  autocal::YamlMap file = autocal::YamlMap::loadFile(calibration_path);
  if (file.has("camera_pose")) {
    autocal::YamlMap pose = file.map("camera_pose");
    const autocal::sim::CameraConfig& t = robot.camera;
    std::printf("%-12s %12s %12s %12s\n", "", "calibrated", "truth", "error");
    auto row = [&](const char* what, const char* key, double truth, double scale) {
      const double f = pose.required<double>(key);
      std::printf("%-12s %12.3f %12.3f %+12.3f\n", what, scale * f, scale * truth,
                  scale * (f - truth));
    };
    const double deg = 180 / M_PI;
    row("height [mm]", "height_m", t.height_m, 1e3);
    row("pitch [deg]", "pitch_rad", t.pitch_rad, deg);
    row("roll [deg]", "roll_rad", t.roll_rad, deg);
    row("yaw [deg]", "yaw_rad", t.yaw_rad, deg);
    row("x [mm]", "x_m", t.x_m, 1e3);
    row("y [mm]", "y_m", t.y_m, 1e3);
  }
  std::printf(
      "ground projection: %.1f mm RMS, %.1f mm worst over %d floor points 0.1-0.6 m ahead\n",
      1e3 * e.rms_m, 1e3 * e.max_m, e.points);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "compare_extrinsics", [&] { return run(argc, argv); }, kUsage);
}
