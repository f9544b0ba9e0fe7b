// The targets of more views where the projection is least sure (view_targets.h).
#include "autocal/camera/view_targets.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace autocal {
namespace camera {

namespace {

/// Azimuth (+ = right in the image) and elevation (+ = up) of a ray at depth 1 in the camera
/// frame [rad]; where the model maps no ray to the pixel, the pinhole's.
cv::Point2d angles(const CameraIntrinsics& fit, const cv::Point3d& ray, const cv::Point2d& pixel) {
  cv::Point2d xy(ray.x, ray.y);
  if (!std::isfinite(xy.x) || !std::isfinite(xy.y))
    xy = {(pixel.x - fit.cx) / fit.fx, (pixel.y - fit.cy) / fit.fy};
  return {std::atan2(xy.x, 1.0), std::atan2(-xy.y, std::hypot(xy.x, 1.0))};
}

}  // namespace

std::vector<ViewTarget> viewTargets(const ProjectionUncertainty& uncertainty,
                                    const CameraIntrinsics& fit,
                                    const std::vector<CalibrationView>& views,
                                    const std::map<int, double>& heading_by_frame,
                                    double current_heading_rad, int regions) {
  std::vector<ViewTarget> out;
  // The corners seen, with the heading of their view.
  std::vector<cv::Point2d> corners;
  std::vector<double> corner_heading;
  std::vector<int> corner_frame;
  for (const CalibrationView& v : views) {
    const auto h = heading_by_frame.find(v.frame_index);
    if (h == heading_by_frame.end()) continue;
    for (const cv::Point2f& p : v.corners) {
      corners.emplace_back(p.x, p.y);
      corner_heading.push_back(h->second);
      corner_frame.push_back(v.frame_index);
    }
  }
  const bool by_sigma = uncertainty.valid && uncertainty.grid.cells() > 0 &&
                        uncertainty.sigma_px.size() == uncertainty.grid.cells();
  const ImageGrid grid = by_sigma ? uncertainty.grid : ImageGrid{};
  const int cols = grid.cols, rows = grid.rows;
  if (corners.empty() || regions < 1 || fit.width <= 0 || fit.height <= 0) return out;

  // How much each cell needs a view.
  const auto cellCentre = [&](int c, int r) { return grid.centre(c, r, fit.width, fit.height); };
  const auto need = [&](int c, int r) {
    if (by_sigma) {
      const double s = uncertainty.sigma_px[r * cols + c];
      return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
    }
    const cv::Point2d centre = cellCentre(c, r);
    double nearest = std::numeric_limits<double>::infinity();
    for (const cv::Point2d& p : corners) nearest = std::min(nearest, std::hypot(p.x - centre.x, p.y - centre.y));
    return nearest;
  };

  const std::vector<cv::Point3d> corner_rays = pixelRays(fit, corners);
  std::vector<cv::Point2d> corner_angles;
  for (size_t i = 0; i < corners.size(); ++i)
    corner_angles.push_back(angles(fit, corner_rays[i], corners[i]));

  for (int g = 0; g < regions; ++g) {
    const int c0 = g * cols / regions, c1 = (g + 1) * cols / regions;
    if (c1 <= c0) continue;
    ViewTarget t;
    t.need = -1;
    for (int r = 0; r < rows; ++r)
      for (int c = c0; c < c1; ++c) {
        const double n = need(c, r);
        if (n > t.need) t.need = n, t.pixel = cellCentre(c, r);
      }
    const cv::Point2d target = angles(fit, pixelRays(fit, {t.pixel})[0], t.pixel);
    // The corner of the nearest elevation; of those within 0.01 rad of it, the least turn away.
    double best_miss = std::numeric_limits<double>::infinity();
    for (const cv::Point2d& a : corner_angles) best_miss = std::min(best_miss, std::abs(a.y - target.y));
    double best_turn = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < corners.size(); ++i) {
      const double miss = std::abs(corner_angles[i].y - target.y);
      if (miss > best_miss + 0.01) continue;
      // Turning counter-clockwise by d moves what is seen at azimuth a to a + d.
      const double heading = corner_heading[i] + (target.x - corner_angles[i].x);
      const double turn = std::abs(heading - current_heading_rad);
      if (turn < best_turn) {
        best_turn = turn;
        t.heading_rad = heading;
        t.corner_px = corners[i];
        t.frame_index = corner_frame[i];
        t.elevation_miss_rad = miss;
      }
    }
    out.push_back(t);
  }
  return out;
}

}  // namespace camera
}  // namespace autocal
