// calibrate_extrinsics: Duckietown's board-on-the-floor ground projection from one raw image.
//   rosrun autocal calibrate_extrinsics --image FILE --camera-info FILE.yaml --out FILE.yaml
// doc/nodes/calibrate_extrinsics.md; exit codes: the one table of doc/calibration_run.md "Exit
// codes" (autocal/exit_codes.h). Needs no master.
#include <cstdio>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "autocal/exit_codes.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/odometry/calibration_file.h"

using namespace autocal;
using namespace autocal::extrinsics;

namespace {

std::string deg(double rad) { return formatNumber(rad * 180 / M_PI, 4); }

int run(const std::vector<std::string>& argv) {
  const ExtrinsicsArgs args = parseExtrinsicsArgs(argv);
  if (args.help) {
    std::cout << kExtrinsicsUsage;
    return 0;
  }
  const CameraInfoRectification camera = loadRectification(args.camera_info);
  const cv::Mat image = readImageFile(args.image, cv::IMREAD_COLOR);
  const FloorBoardResult r = calibrateFromFloorBoard(image, camera, args.options);
  writeFileAtomically(
      args.out, extrinsicsYaml(r.homography, r.mount, &r.mount_sigma,
                               {{"board_rms_m", r.board_rms_m}, {"board_max_m", r.board_max_m}},
                               camera.rectified, args.image, utcNowIso8601()));
  const CameraMount& m = r.mount;
  const CameraMount& s = r.mount_sigma;
  std::printf(
      "wrote %s\n  camera height %.1f mm (±%.1f), pitch %s deg (±%s), roll %s deg (±%s), yaw %s "
      "deg (±%s), %.1f mm ahead of the axle (±%.1f), %.1f mm left (±%.1f)\n  board: %.2f mm RMS, "
      "%.2f mm worst on the floor, %.3f px RMS in the image\n",
      args.out.c_str(), 1e3 * m.height_m, 1e3 * s.height_m, deg(m.pitch_rad).c_str(),
      deg(s.pitch_rad).c_str(), deg(m.roll_rad).c_str(), deg(s.roll_rad).c_str(),
      deg(m.yaw_rad).c_str(), deg(s.yaw_rad).c_str(), 1e3 * m.x_m, 1e3 * s.x_m, 1e3 * m.y_m,
      1e3 * s.y_m, 1e3 * r.board_rms_m, 1e3 * r.board_max_m, r.reprojection_rms_px);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return runCommand(
      "calibrate_extrinsics", [&] { return run(args); }, kExtrinsicsUsage);
}
