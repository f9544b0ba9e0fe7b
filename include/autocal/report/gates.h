// The report's view of the camera stage's audit (camera_intrinsic/<veh>_views/views.yaml) and the
// run's gates: each stage's own verdict (its DONE after its quality gate, or its FAILED), with the
// figures its gate judged. The report adds no gate of its own: there is one gate. ROS-free.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/report/run_record.h"

namespace autocal {
namespace report {

/// One view of the camera stage's audit (camera_intrinsic/<veh>_views/views.yaml).
struct AuditView {
  std::string image;  ///< path of its PNG
  double rms_px = 0;
  std::vector<cv::Point2f> corners;
};
struct ViewsAudit {
  bool loaded = false;
  cv::Size image_size;
  double rms_px = 0;
  std::vector<AuditView> views;
  /// The projection uncertainty over a cols x rows grid (views.yaml projection_uncertainty):
  /// each cell's standard deviation in its worst direction [px], row-major; empty when the audit
  /// has none.
  int uncertainty_cols = 0, uncertainty_rows = 0;
  std::vector<double> uncertainty_px;
  double uncertainty_worst_px = 0, uncertainty_lower_half_worst_px = 0;
};
/// Reads the audit; throws ConfigError (file and line) on a malformed file, IoError when missing.
ViewsAudit loadViewsAudit(const std::string& views_yaml);

/// Share of the cells of a cols × rows grid over the image that hold a board corner of some view.
double cornerCoverage(const ViewsAudit& audit, int cols = 8, int rows = 6);

struct ReportOptions {
  double wheel_radius_m = 0.0318;  ///< for the believed path (the kinematics file's, when written)
  double baseline_m = 0.1;
};

struct Gate {
  std::string name;
  bool passed = false;
  std::string detail;
};

/// One gate per stage: its own verdict ("done", its failure, or how far it got). A camera stage's
/// detail adds the figures its quality gate judged (RMS, the lower half's projection uncertainty,
/// the halves' cross-validation ratio).
std::vector<Gate> evaluateGates(const RunRecord& record);

}  // namespace report
}  // namespace autocal
