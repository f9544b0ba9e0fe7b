// camera_extrinsic/<veh>.yaml: Duckietown's ground projection file, and the offline command's
// command line (`rosrun autocal calibrate_extrinsics`, doc/nodes/calibrate_extrinsics.md).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "autocal/extrinsics/floor_board.h"
#include "autocal/extrinsics/tag_mount.h"

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

/// The extrinsics file's keys a later stage needs to correct its mount for the turn of the
/// straight drives it came from (the wheel stage's hops, taken as straight).
constexpr const char* kYawPerTurnKey = "yaw_per_turn_per_m";  ///< TagMountResult's
constexpr const char* kStraightSpeedKey = "straight_speed_mps";  ///< the hops' speed
constexpr const char* kStraightTurnKey = "straight_turn_per_m";  ///< the turn applied so far

/// What correctForStraightTurn did.
struct StraightTurnCorrection {
  bool corrected = false;
  double turn_per_m = 0;  ///< the straight drives' turn the file is now for [rad/m]
  double yaw_change_rad = 0;
  CameraMount mount;      ///< the file's mount now
  std::string why_not;    ///< when not corrected: why
};

/// Rewrites the extrinsics file at `path` (the wheel stage's, with kYawPerTurnKey) for straight
/// drives that turned by `turn_per_m` per metre instead of what it was for (kStraightTurnKey, else
/// none): the mount moved by mountForStraightTurn, its homography through `camera` (which must be
/// the camera its projection_matrix names), every other key kept. Atomically, an existing .prev
/// kept. Not corrected (why_not says why, nothing written) when there is no such file or it has no
/// kYawPerTurnKey. Throws ConfigError for a file that cannot be read or another camera, IoError.
StraightTurnCorrection correctForStraightTurn(const std::string& path, double turn_per_m,
                                              const CameraInfoRectification& camera,
                                              const std::string& source,
                                              const std::string& time_utc);

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
