#include "autocal/camera/camera_config.h"

#include <cstdio>

#include "autocal/errors.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {
namespace camera {

cv::Size parseBoardSize(const std::string& text) {
  int cols = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &cols, &x, &rows, &extra) != 3 ||
      (x != 'x' && x != 'X') || cols < 3 || rows < 3) {
    throw ConfigError("board '" + text +
                      "': expected inner corners as COLSxROWS, e.g. 9x6 (each >= 3)");
  }
  if (cols == rows) {
    throw ConfigError("board '" + text +
                      "': a square board's orientation is ambiguous; use one with "
                      "different numbers of inner corners per row and column");
  }
  return cv::Size(cols, rows);
}

void CameraCalibrationConfig::validate() const {
  board.validate();
  checkConfig(detector.max_boards >= 1, "detection.max_boards", "must be >= 1");
  checkConfig(detector.refine_window_ratio > 0 && detector.refine_window_ratio < 0.5,
              "detection.refine_window_ratio",
              "must be in (0, 0.5): the window must not reach the next corner");
  checkConfig(detector.refine_min_half_window_px >= 1 &&
                  detector.refine_max_half_window_px >= detector.refine_min_half_window_px,
              "detection.refine_max_half_window_px", "must be >= refine_min_half_window_px >= 1");
  checkConfig(selection.min_novelty >= 0, "view_selection.min_novelty", "must be >= 0");
  checkConfig(selection.max_views >= selection.min_views && selection.min_views >= 1,
              "view_selection.max_views", "must be >= min_views >= 1");
  checkConfig(selection.max_edge_width_px > 0, "view_selection.max_edge_width_px", "must be > 0");
  checkConfig(selection.min_edge_distance_spacings >= 0, "view_selection.min_edge_distance_spacings",
              "must be >= 0");
  checkConfig(selection.nominal_focal_width_ratio > 0, "view_selection.nominal_focal_width_ratio",
              "must be > 0");
  checkConfig(selection.max_distance_m > 0, "view_selection.max_distance_m", "must be > 0");
  checkConfig(calibration.min_views >= 4, "calibration.min_views", "must be >= 4");
  checkConfig(calibration.threads >= 0, "calibration.threads", "must be >= 0 (0: one per core)");
  checkConfig(calibration.min_term_significance > 0, "calibration.min_term_significance",
              "must be > 0");
  checkConfig(calibration.selection_margin >= 0, "calibration.selection_margin", "must be >= 0");
  checkConfig(calibration.model_rms_margin >= 0, "calibration.model_rms_margin", "must be >= 0");
  checkConfig(calibration.model_corner_cap_factor > 0, "calibration.model_corner_cap_factor",
              "must be > 0");
  checkConfig(calibration.model_uncertainty_margin >= 0 && calibration.model_uncertainty_margin <= 1,
              "calibration.model_uncertainty_margin", "must be in [0, 1]");
  checkConfig(calibration.max_selection_folds >= 2, "calibration.max_selection_folds",
              "must be >= 2");
  checkConfig(calibration.outlier_view_factor > 1, "calibration.outlier_view_factor",
              "must be > 1");
  checkConfig(calibration.outlier_corner_factor > 1, "calibration.outlier_corner_factor",
              "must be > 1");
  checkConfig(calibration.halves_outlier_view_factor > 1,
              "calibration.halves_outlier_view_factor", "must be > 1");
  checkConfig(calibration.max_halves_outlier_views >= 0 &&
                  calibration.max_halves_outlier_views <= 5,
              "calibration.max_halves_outlier_views", "must be within [0, 5]");
  checkConfig(
      calibration.max_outlier_corner_fraction > 0 && calibration.max_outlier_corner_fraction < 1,
      "calibration.max_outlier_corner_fraction", "must be in (0, 1)");
  checkConfig(calibration.max_outlier_rounds >= 1, "calibration.max_outlier_rounds",
              "must be >= 1");
  checkConfig(calibration.min_kept_fraction > 0 && calibration.min_kept_fraction <= 1,
              "calibration.min_kept_fraction", "must be in (0, 1]");
  checkConfig(quality_gate.max_rms_px > 0, "quality_gate.max_rms_px", "must be > 0");
  checkConfig(quality_gate.max_view_rms_px > 0, "quality_gate.max_view_rms_px", "must be > 0");
  checkConfig(quality_gate.min_views >= calibration.min_views, "quality_gate.min_views",
              "must be >= calibration.min_views");
  checkConfig(quality_gate.max_lower_half_uncertainty_px > 0,
              "quality_gate.max_lower_half_uncertainty_px", "must be > 0 [px]");
  checkConfig(quality_gate.max_halves_ratio > 0, "quality_gate.max_halves_ratio", "must be > 0");
  checkConfig(quality_gate.max_model_difference_px > 0, "quality_gate.max_model_difference_px",
              "must be > 0");
  checkConfig(quality_gate.min_views_per_half >= 4, "quality_gate.min_views_per_half",
              "must be >= 4");
}

CameraCalibrationConfig loadCameraCalibrationConfig(const std::string& path) {
  YamlMap root = YamlMap::loadFile(path);
  CameraCalibrationConfig c;
  {
    YamlMap b = root.map("board");
    c.board.inner_corners = parseBoardSize(b.required<std::string>("inner_corners"));
    c.board.square_size_m = b.required<double>("square_size_m");
    b.finish();
  }
  {
    YamlMap d = root.map("detection");
    c.detector.max_boards = d.required<int>("max_boards");
    c.detector.fast_check = d.required<bool>("fast_check");
    c.detector.half_resolution_precheck = d.required<bool>("half_resolution_precheck");
    c.detector.adaptive_threshold = d.required<bool>("adaptive_threshold");
    c.detector.refine_window_ratio = d.required<double>("refine_window_ratio");
    c.detector.refine_min_half_window_px = d.required<int>("refine_min_half_window_px");
    c.detector.refine_max_half_window_px = d.required<int>("refine_max_half_window_px");
    c.detector.refine_through_lens =
        d.optional<bool>("refine_through_lens", c.detector.refine_through_lens);
    d.finish();
  }
  {
    YamlMap s = root.map("view_selection");
    c.selection.min_novelty = s.required<double>("min_novelty");
    const std::vector<double> goal = s.required<std::vector<double>>("goal_spread");
    if (goal.size() != 6)
      s.fail("goal_spread", "expected 6 numbers: x, y, size, skew, distance, tilt");
    for (size_t i = 0; i < 6; ++i) c.selection.goal_spread[i] = goal[i];
    c.selection.min_views = s.required<int>("min_views");
    c.selection.max_views = s.required<int>("max_views");
    c.selection.nominal_focal_width_ratio = s.required<double>("nominal_focal_width_ratio");
    c.selection.max_distance_m = s.required<double>("max_distance_m");
    c.selection.max_edge_width_px = s.required<double>("max_edge_width_px");
    c.selection.min_edge_distance_spacings = s.optional<double>(
        "min_edge_distance_spacings", c.selection.min_edge_distance_spacings);
    c.selection.keep_sharp_views = s.required<bool>("keep_sharp_views");
    s.finish();
  }
  {
    YamlMap k = root.map("calibration");
    c.calibration.model = parseDistortionModel(k.required<std::string>("distortion_model"));
    if (k.has("fallback_models")) {
      c.calibration.fallback_models.clear();
      for (const std::string& m : k.required<std::vector<std::string>>("fallback_models"))
        c.calibration.fallback_models.push_back(parseDistortionModel(m));
    }
    c.calibration.model_corner_cap_factor =
        k.optional<double>("model_corner_cap_factor", c.calibration.model_corner_cap_factor);
    c.calibration.model_rms_margin =
        k.optional<double>("model_rms_margin", c.calibration.model_rms_margin);
    c.calibration.model_uncertainty_margin =
        k.optional<double>("model_uncertainty_margin", c.calibration.model_uncertainty_margin);
    c.calibration.min_views = k.required<int>("min_views");
    c.calibration.min_param_spread = k.required<double>("min_param_spread");
    c.calibration.select_distortion_terms = k.required<bool>("select_distortion_terms");
    const std::string selection = k.required<std::string>("selection");
    if (selection == "significance") {
      c.calibration.selection = CalibrationOptions::Selection::kSignificance;
    } else if (selection == "holdout") {
      c.calibration.selection = CalibrationOptions::Selection::kHoldout;
    } else {
      k.fail("selection", "expected significance or holdout, got '" + selection + "'");
    }
    c.calibration.min_term_significance = k.required<double>("min_term_significance");
    c.calibration.selection_margin = k.required<double>("selection_margin");
    c.calibration.max_selection_folds = k.required<int>("max_selection_folds");
    c.calibration.outlier_view_factor = k.required<double>("outlier_view_factor");
    c.calibration.outlier_view_min_px = k.required<double>("outlier_view_min_px");
    c.calibration.outlier_corner_factor = k.required<double>("outlier_corner_factor");
    c.calibration.outlier_corner_min_px = k.required<double>("outlier_corner_min_px");
    c.calibration.max_outlier_corner_fraction = k.required<double>("max_outlier_corner_fraction");
    c.calibration.max_outlier_rounds = k.required<int>("max_outlier_rounds");
    c.calibration.halves_outlier_view_factor =
        k.optional<double>("halves_outlier_view_factor", c.calibration.halves_outlier_view_factor);
    c.calibration.max_halves_outlier_views =
        k.optional<int>("max_halves_outlier_views", c.calibration.max_halves_outlier_views);
    c.calibration.min_kept_fraction = k.required<double>("min_kept_fraction");
    c.calibration.threads = k.optional<int>("threads", c.calibration.threads);
    k.finish();
  }
  {
    YamlMap q = root.map("quality_gate");
    c.quality_gate.max_rms_px = q.required<double>("max_rms_px");
    c.quality_gate.max_view_rms_px = q.required<double>("max_view_rms_px");
    c.quality_gate.min_views = q.required<int>("min_views");
    c.quality_gate.max_focal_rel_std = q.required<double>("max_focal_rel_std");
    c.quality_gate.max_principal_offset_ratio = q.required<double>("max_principal_offset_ratio");
    c.quality_gate.max_lower_half_uncertainty_px = q.optional<double>(
        "max_lower_half_uncertainty_px", c.quality_gate.max_lower_half_uncertainty_px);
    c.quality_gate.max_halves_ratio =
        q.optional<double>("max_halves_ratio", c.quality_gate.max_halves_ratio);
    c.quality_gate.min_views_per_half =
        q.optional<int>("min_views_per_half", c.quality_gate.min_views_per_half);
    c.quality_gate.max_model_difference_px =
        q.optional<double>("max_model_difference_px", c.quality_gate.max_model_difference_px);
    q.finish();
  }
  root.finish();
  try {
    c.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return c;
}

CameraCalibrationConfig loadStageCameraConfig(const std::string& path,
                                              const std::string& board_inner_corners,
                                              double board_square_m) {
  CameraCalibrationConfig camera = loadCameraCalibrationConfig(path);
  if (!board_inner_corners.empty())
    camera.board.inner_corners = parseBoardSize(board_inner_corners);
  if (board_square_m > 0) camera.board.square_size_m = board_square_m;
  camera.detector.half_resolution_precheck = false;
  camera.validate();
  return camera;
}

}  // namespace camera
}  // namespace autocal
