// camera_extrinsic/<veh>.yaml and the offline command's arguments (see extrinsics_file.h).
#include "autocal/extrinsics/extrinsics_file.h"

#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/extrinsics/ground_projection.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {
namespace extrinsics {

namespace {

std::string list(const Eigen::Matrix3d& m) {
  std::string s = "[";
  for (int i = 0; i < 9; ++i) s += (i ? ", " : "") + formatNumber(m(i / 3, i % 3), 10);
  return s + "]";
}

std::string mountMap(const CameraMount& m) {
  return "{height_m: " + formatNumber(m.height_m, 6) +
         ", pitch_rad: " + formatNumber(m.pitch_rad, 6) +
         ", roll_rad: " + formatNumber(m.roll_rad, 6) + ", yaw_rad: " + formatNumber(m.yaw_rad, 6) +
         ", x_m: " + formatNumber(m.x_m, 6) + ", y_m: " + formatNumber(m.y_m, 6) + "}";
}

}  // namespace

std::string extrinsicsYaml(const Eigen::Matrix3d& homography, const CameraMount& mount,
                           const CameraMount* sigma,
                           const std::vector<std::pair<std::string, double>>& figures,
                           const RectifiedCamera& camera, const std::string& source,
                           const std::string& time_utc) {
  std::ostringstream y;
  y << "# autocal camera extrinsics, " << time_utc << ", from " << source << "\n"
    << "# homography: a pixel (u, v) of the image rectified with projection_matrix to the floor\n"
    << "# point (x forward, y left, metres; origin below the middle of the wheel axle):\n"
    << "# [x, y, w] = H [u, v, 1], point (x/w, y/w) (dt-core GroundProjectionGeometry).\n"
    << "homography: " << list(homography) << "\n"
    << "# the camera's pose on the robot it comes from"
    << (sigma ? ", and one standard deviation of each" : "") << "\n"
    << "camera_pose: " << mountMap(mount) << "\n";
  if (sigma) y << "camera_pose_sigma: " << mountMap(*sigma) << "\n";
  for (const auto& [key, value] : figures) y << key << ": " << formatNumber(value, 4) << "\n";
  y << "# the left 3x3 of the camera_info's P the homography is for\n"
    << "projection_matrix: " << list(camera.P) << "\n";
  return y.str();
}

std::string extrinsicsPath(const std::string& calibration_root, const std::string& vehicle) {
  if (vehicle.empty() || vehicle.find('/') != std::string::npos)
    throw ConfigError("vehicle name must be a non-empty name without '/', got '" + vehicle + "'");
  if (calibration_root.empty()) throw ConfigError("calibration_root must not be empty");
  return calibration_root + "/camera_extrinsic/" + vehicle + ".yaml";
}

std::string groundViewPath(const std::string& extrinsics_yaml) {
  const std::string suffix = ".yaml";
  const bool yaml =
      extrinsics_yaml.size() > suffix.size() &&
      extrinsics_yaml.compare(extrinsics_yaml.size() - suffix.size(), suffix.size(), suffix) == 0;
  return (yaml ? extrinsics_yaml.substr(0, extrinsics_yaml.size() - suffix.size())
               : extrinsics_yaml) +
         "_ground.png";
}

Eigen::Matrix3d readHomography(const std::string& path) {
  YamlMap y = YamlMap::loadFile(path);
  const std::vector<double> h = y.required<std::vector<double>>("homography");
  if (h.size() != 9) y.fail("homography", "must be 9 numbers (row-major 3x3)");
  Eigen::Matrix3d H;
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(h[static_cast<size_t>(i)])) y.fail("homography", "must be finite numbers");
    H(i / 3, i % 3) = h[static_cast<size_t>(i)];
  }
  return H;
}

const char* const kExtrinsicsUsage =
    "usage: rosrun autocal calibrate_extrinsics --image FILE --camera-info FILE.yaml --out "
    "FILE.yaml\n"
    "           [--board 7x5] [--square 0.031] [--offset-x 0.191] [--offset-y 0.093]\n"
    "           [--max-board-rms 0.003]\n"
    "Duckietown's board-on-the-floor extrinsics from one raw image: the board (inner corners\n"
    "across x along the robot) lies flat in front of the robot, its nearest corner row offset-x\n"
    "metres ahead of the wheel axle, its rightmost corner column offset-y metres right of the\n"
    "centre line (the defaults are Duckietown's). The image is rectified with the camera_info's\n"
    "K, D, R and P; the homography written is for that P. Refused (nothing written) when the\n"
    "board is not found, its corners lie off the fitted pose, or the pose is none a Duckiebot can\n"
    "have. Needs no master.\n"
    "Exit status: 0 written; 1 refused; 2 unusable image; 3 bad camera_info; 4 cannot write;\n"
    "  64 bad command line.\n";

ExtrinsicsArgs parseExtrinsicsArgs(const std::vector<std::string>& args) {
  ExtrinsicsArgs a;
  FloorBoard& b = a.options.board;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "-h" || flag == "--help") {
      a.help = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + flag + "'");
    if (i + 1 >= args.size()) throw UsageError(flag + ": missing value (or unknown option)");
    const std::string& value = args[++i];
    if (flag == "--image") {
      a.image = value;
    } else if (flag == "--camera-info") {
      a.camera_info = value;
    } else if (flag == "--out") {
      a.out = value;
    } else if (flag == "--board") {
      const size_t x = value.find('x');
      if (x == std::string::npos)
        throw UsageError(flag + ": expected COLSxROWS, got '" + value + "'");
      b.cols = parseIntArg(flag, value.substr(0, x));
      b.rows = parseIntArg(flag, value.substr(x + 1));
    } else if (flag == "--square") {
      b.square_m = parseNumberArg(flag, value);
    } else if (flag == "--offset-x") {
      b.offset_x_m = parseNumberArg(flag, value);
    } else if (flag == "--offset-y") {
      b.offset_y_m = parseNumberArg(flag, value);
    } else if (flag == "--max-board-rms") {
      a.options.max_board_rms_m = parseNumberArg(flag, value);
    } else {
      throw UsageError("unknown option " + flag);
    }
  }
  if (a.help) return a;
  if (a.image.empty()) throw UsageError("--image FILE is required");
  if (a.camera_info.empty()) throw UsageError("--camera-info FILE.yaml is required");
  if (a.out.empty()) throw UsageError("--out FILE.yaml is required");
  try {
    b.validate();
  } catch (const ConfigError& e) {
    throw UsageError(e.what());
  }
  if (!(a.options.max_board_rms_m > 0)) throw UsageError("--max-board-rms: must be > 0 [m]");
  return a;
}

namespace {

CameraMount readMount(YamlMap& y, const std::string& key) {
  YamlMap m = y.map(key);
  CameraMount out;
  out.height_m = m.required<double>("height_m");
  out.pitch_rad = m.required<double>("pitch_rad");
  out.roll_rad = m.required<double>("roll_rad");
  out.yaw_rad = m.required<double>("yaw_rad");
  out.x_m = m.required<double>("x_m");
  out.y_m = m.required<double>("y_m");
  return out;
}

}  // namespace

StraightTurnCorrection correctForStraightTurn(const std::string& path, double turn_per_m,
                                              const CameraInfoRectification& camera,
                                              const std::string& source,
                                              const std::string& time_utc) {
  StraightTurnCorrection c;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    c.why_not = "no extrinsics file at " + path;
    return c;
  }
  YamlMap y = YamlMap::loadFile(path);
  if (!y.has(kYawPerTurnKey)) {
    c.why_not = path + " has no " + std::string(kYawPerTurnKey);
    return c;
  }
  const double yaw_per_turn = y.required<double>(kYawPerTurnKey);
  const double before = y.optional<double>(kStraightTurnKey, 0.0);
  const std::vector<double> p = y.required<std::vector<double>>("projection_matrix");
  if (p.size() != 9) y.fail("projection_matrix", "must be 9 numbers (row-major 3x3)");
  for (int i = 0; i < 9; ++i) {
    if (std::abs(p[static_cast<size_t>(i)] - camera.rectified.P(i / 3, i % 3)) >
        1e-6 * (1 + std::abs(p[static_cast<size_t>(i)]))) {
      y.fail("projection_matrix", "is not the camera_info's P given: the file is for another "
                                  "calibration of the camera");
    }
  }
  const CameraMount old = readMount(y, "camera_pose");
  std::optional<CameraMount> sigma;
  if (y.has("camera_pose_sigma")) sigma = readMount(y, "camera_pose_sigma");
  std::vector<std::pair<std::string, double>> figures;
  for (const char* key :
       {"plane_rms_m", "rejected_sightings", "turn_centre_rms_m", "yaw_spread_rad", "drives",
        "passes", "turns", kYawPerTurnKey, kStraightSpeedKey}) {
    if (y.has(key)) figures.emplace_back(key, y.required<double>(key));
  }
  figures.emplace_back(kStraightTurnKey, turn_per_m);
  c.mount = mountForStraightTurn(old, yaw_per_turn, turn_per_m - before);
  const Eigen::Matrix3d H = homographyFromMount(c.mount, camera.rectified);
  // In a run the wheel stage wrote this file a moment ago and kept the one from before the run as
  // `.prev`: that one stays. Without a `.prev`, the file replaced becomes it.
  AtomicWriteOptions write;
  if (std::filesystem::exists(path + ".prev", ec)) write.backup_suffix.clear();
  writeFileAtomically(path,
                      extrinsicsYaml(H, c.mount, sigma ? &*sigma : nullptr, figures,
                                     camera.rectified, source, time_utc),
                      write);
  c.corrected = true;
  c.turn_per_m = turn_per_m;
  c.yaw_change_rad = c.mount.yaw_rad - old.yaw_rad;
  return c;
}

CameraInfoRectification loadRectification(const std::string& path) {
  const CameraInfoFile f = loadCameraInfoFile(path);
  if (std::abs(f.projection(0, 3)) > 1e-9 || std::abs(f.projection(1, 3)) > 1e-9 ||
      std::abs(f.projection(2, 3)) > 1e-9) {
    throw ConfigError(path +
                      ": projection_matrix has a non-zero fourth column (a stereo pair's "
                      "second camera): the ground homography is for a monocular camera");
  }
  CameraInfoRectification c;
  c.intrinsics = f.intrinsics;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) {
      c.rectified.P(r, k) = f.projection(r, k);
      c.rectified.R(r, k) = f.rectification(r, k);
    }
  }
  return c;
}

}  // namespace extrinsics
}  // namespace autocal
