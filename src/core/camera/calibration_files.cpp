#include "autocal/camera/calibration_files.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"

namespace autocal {
namespace camera {

std::string cameraIntrinsicsPath(const std::string& calibration_root, const std::string& veh) {
  return (std::filesystem::path(calibration_root) / "camera_intrinsic" / (veh + ".yaml")).string();
}

StageResult writeCameraStageFile(const StageOutput& output, const CameraInfoFormat& format,
                                 const BoardSpec& board, const CalibrationResult& result,
                                 const std::vector<CalibrationView>& views,
                                 const std::map<int, cv::Mat>& frames) {
  if (!format) throw ConfigError("writeCameraStageFile: no camera_info format");
  StageResult r;
  r.file = cameraIntrinsicsPath(output.calibration_root, output.veh);
  writeCameraCalibration(r.file, format(result.intrinsics, output.veh), board, result, views,
                         frames);
  const CameraIntrinsics& in = result.intrinsics;
  r.figures = calibrationFigures(result);
  r.log = "fx " + formatNumber(in.fx, 6) + " fy " + formatNumber(in.fy, 6) + " cx " +
          formatNumber(in.cx, 6) + " cy " + formatNumber(in.cy, 6) + " k1 " +
          formatNumber(in.distortion_coefficients[0], 4) + ", RMS " +
          formatNumber(result.rms_px, 3) + " px over " + std::to_string(result.used_views.size()) +
          " views (" + distortionModelName(in.distortion_model) + ", " + result.fitted_terms + ")";
  if (!result.refused_models.empty()) r.log += "; refused first: " + result.refused_models;
  return r;
}

Figures calibrationFigures(const CalibrationResult& result) {
  const CameraIntrinsics& in = result.intrinsics;
  Figures f = {{"fx", in.fx},
               {"fy", in.fy},
               {"cx", in.cx},
               {"cy", in.cy},
               {"k1", in.distortion_coefficients[0]},
               {"k2", in.distortion_coefficients[1]},
               {"rms_px", result.rms_px},
               {"views", static_cast<double>(result.used_views.size())}};
  const ProjectionUncertainty& u = result.uncertainty;
  if (u.valid) {
    f.emplace_back("uncertainty_rms_px", u.rms_px);
    f.emplace_back("uncertainty_worst_px", u.worst_px);
    f.emplace_back("uncertainty_lower_half_worst_px", u.lower_half_worst_px);
  }
  if (result.halves.valid) f.emplace_back("halves_ratio", result.halves.ratio);
  return f;
}

namespace fs = std::filesystem;

namespace {
std::string viewImageName(size_t used_index) {
  char name[32];
  std::snprintf(name, sizeof name, "view_%03zu.png", used_index);
  return name;
}

void removeAll(const fs::path& p) {
  std::error_code ec;
  fs::remove_all(p, ec);
}

void renameOrThrow(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) {
    throw IoError("cannot rename '" + from.string() + "' to '" + to.string() +
                  "': " + ec.message());
  }
}
}  // namespace

std::string viewsDirFor(const std::string& yaml_path) {
  const fs::path p(yaml_path);
  return (p.parent_path() / (p.stem().string() + "_views")).string();
}

std::string viewsYaml(const BoardSpec& board, const CalibrationResult& result,
                      const std::vector<CalibrationView>& views, const std::string& written_for) {
  std::ostringstream y;
  y << "# Views used for " << written_for << "; corners in pixels, pattern row-major order\n";
  y << "board: {inner_corners: " << board.inner_corners.width << "x" << board.inner_corners.height
    << ", square_size_m: " << formatNumber(board.square_size_m) << "}\n";
  y << "image: {width: " << result.intrinsics.width << ", height: " << result.intrinsics.height
    << "}\n";
  y << "distortion_model: " << distortionModelName(result.intrinsics.distortion_model) << "\n";
  y << "rms_px: " << formatNumber(result.rms_px) << "\nfitted_terms: \"" << result.fitted_terms
    << "\"\noutlier_corners_dropped: " << result.dropped_corners << "\n";
  if (!result.refused_models.empty()) {
    std::string quoted = result.refused_models;
    for (size_t p = 0; (p = quoted.find('"', p)) != std::string::npos; p += 2)
      quoted.insert(p, "\\");
    y << "refused_models: \"" << quoted << "\"\n";
  }
  const ProjectionUncertainty& pu = result.uncertainty;
  if (pu.valid) {
    y << "projection_uncertainty:\n  grid: [" << pu.grid.cols << ", " << pu.grid.rows
      << "]\n  corner_noise_px: " << formatNumber(pu.corner_noise_px, 4)
      << "\n  rms_px: " << formatNumber(pu.rms_px, 4)
      << "\n  worst_px: " << formatNumber(pu.worst_px, 4)
      << "\n  lower_half_worst_px: " << formatNumber(pu.lower_half_worst_px, 4)
      << "\n  sigma_px: [";
    for (size_t i = 0; i < pu.sigma_px.size(); ++i)
      y << (i ? ", " : "")
        << (std::isfinite(pu.sigma_px[i]) ? formatNumber(pu.sigma_px[i], 4) : "-1");
    y << "]\n";
  }
  const HalvesCrossValidation& h = result.halves;
  if (h.valid) {
    y << "halves_cross_validation: {views_each: " << h.views_each
      << ", rms_px: " << formatNumber(h.rms_px, 4) << ", worst_px: " << formatNumber(h.worst_px, 4)
      << ", expected_rms_px: " << formatNumber(h.expected_rms_px, 4)
      << ", ratio: " << formatNumber(h.ratio, 3) << "}\n";
  }
  y << "views:\n";
  for (size_t u = 0; u < result.used_views.size(); ++u) {
    const CalibrationView& v = views.at(static_cast<size_t>(result.used_views[u]));
    y << "  - image: " << viewImageName(u) << "\n    source: \"" << v.source
      << "\"\n    rms_px: " << formatNumber(result.per_view_rms_px[u]) << "\n    corners: [";
    for (size_t c = 0; c < v.corners.size(); ++c) {
      y << (c ? ", " : "") << "[" << formatNumber(v.corners[c].x) << ", "
        << formatNumber(v.corners[c].y) << "]";
    }
    y << "]\n";
  }
  return y.str();
}

void writeCameraCalibration(const std::string& yaml_path, const std::string& yaml_text,
                            const BoardSpec& board, const CalibrationResult& result,
                            const std::vector<CalibrationView>& views,
                            const std::map<int, cv::Mat>& frames) {
  const fs::path yaml(yaml_path);
  const fs::path dir = fs::path(viewsDirFor(yaml_path));
  const fs::path prev_dir = dir.string() + ".prev";
  std::error_code ec;
  fs::create_directories(dir.parent_path().empty() ? fs::path(".") : dir.parent_path(), ec);
  if (ec) throw IoError("cannot create '" + dir.parent_path().string() + "': " + ec.message());

  // 1. The new folder, complete, under a temporary name.
  std::string tmpl = (dir.parent_path() / ("." + dir.filename().string() + ".tmpXXXXXX")).string();
  if (!::mkdtemp(tmpl.data())) {
    throw IoError("cannot create a temporary folder beside '" + dir.string() + "'");
  }
  const fs::path tmp(tmpl);
  try {
    // mkdtemp makes it private (0700); the folder it becomes is read like the YAML beside it.
    fs::permissions(tmp, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                             fs::perms::others_read | fs::perms::others_exec);
    for (size_t u = 0; u < result.used_views.size(); ++u) {
      const CalibrationView& v = views.at(static_cast<size_t>(result.used_views[u]));
      const auto frame = frames.find(v.frame_index);
      if (frame == frames.end()) {
        throw IoError("no frame kept for view " + std::to_string(u) + " (" + v.source + ")");
      }
      writePngAtomically((tmp / viewImageName(u)).string(), frame->second,
                         AtomicWriteOptions{"", false});
    }
    writeFileAtomically((tmp / "views.yaml").string(),
                        viewsYaml(board, result, views, yaml.filename().string()),
                        AtomicWriteOptions{"", false});
  } catch (...) {
    removeAll(tmp);
    throw;
  }

  // 2. Swap the folders: the old one becomes .prev only when its YAML exists too.
  const bool had_yaml = fs::exists(yaml, ec);
  const bool had_dir = fs::exists(dir, ec);
  removeAll(prev_dir);
  try {
    if (had_dir) {
      if (had_yaml) {
        renameOrThrow(dir, prev_dir);
      } else {
        removeAll(dir);
      }
    }
    renameOrThrow(tmp, dir);
  } catch (...) {
    removeAll(tmp);
    if (had_dir && had_yaml && !fs::exists(dir, ec)) renameOrThrow(prev_dir, dir);
    throw;
  }

  // 3. The YAML (its previous version kept as .prev by the atomic write).
  try {
    writeFileAtomically(yaml_path, yaml_text);
  } catch (...) {
    removeAll(dir);
    if (had_dir && had_yaml) renameOrThrow(prev_dir, dir);
    throw;
  }
  if (!had_yaml) {
    // A stale <yaml>.prev from before would not match the (absent) previous folder.
    fs::remove(yaml_path + ".prev", ec);
  }
}

}  // namespace camera
}  // namespace autocal
