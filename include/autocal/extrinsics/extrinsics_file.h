// camera_extrinsic/<veh>.yaml: Duckietown's ground projection file, and the offline command's
// command line (`rosrun autocal calibrate_extrinsics`, doc/nodes/calibrate_extrinsics.md).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "autocal/extrinsics/floor_board.h"

namespace autocal {
namespace extrinsics {

/// The file's text. `homography` (9 numbers, row-major) is the key Duckietown reads (its
/// version-1 form: pixels of the rectified image at the camera_info's own resolution); the others
/// are autocal's: the camera pose it comes from, one standard deviation of each number when known
/// (`sigma`), how well the data fit (`figures`, e.g. board_rms_m), and the P it is for. A comment
/// gives the time and the source.
std::string extrinsicsYaml(const Eigen::Matrix3d& homography, const CameraMount& mount,
                           const CameraMount* sigma,
                           const std::vector<std::pair<std::string, double>>& figures,
                           const RectifiedCamera& camera, const std::string& source,
                           const std::string& time_utc);

/// camera_extrinsic/<veh>.yaml under a calibration root; throws ConfigError on an empty root or
/// a vehicle name with '/'.
std::string extrinsicsPath(const std::string& calibration_root, const std::string& vehicle);

/// The ground view beside an extrinsics file: `<veh>_ground.png` for `<veh>.yaml` (the floor
/// grid the homography gives, over the stage's last still, rectified).
std::string groundViewPath(const std::string& extrinsics_yaml);

/// The homography of such a file (Duckietown's or autocal's). Throws ConfigError naming the file
/// when it has no 9 finite numbers under `homography`.
Eigen::Matrix3d readHomography(const std::string& path);

struct ExtrinsicsArgs {
  std::string image, camera_info, out;
  FloorBoardOptions options;
  bool help = false;
};

extern const char* const kExtrinsicsUsage;

/// Throws UsageError on a bad command line.
ExtrinsicsArgs parseExtrinsicsArgs(const std::vector<std::string>& args);

/// The camera_info's rectified camera (P's left 3x3 and R) with its intrinsics; throws
/// ConfigError when P's fourth column is not zero (a stereo camera's right image).
CameraInfoRectification loadRectification(const std::string& camera_info_path);

}  // namespace extrinsics
}  // namespace autocal
