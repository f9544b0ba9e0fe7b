#include "autocal/wheels/tag_heading.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "autocal/errors.h"

namespace autocal {
namespace wheels {

double wrapAngle(double a) {
  a = std::remainder(a, 2 * M_PI);
  return a <= -M_PI ? a + 2 * M_PI : a;
}

void CameraMount::validate() const {
  if (!(height_m > 0 && height_m < 5))
    throw ConfigError("camera_height_m: must be within (0, 5) [m]");
  if (!(std::abs(pitch_rad) < 1.4))
    throw ConfigError("camera_pitch_rad: must be within (-1.4, 1.4) [rad]");
  if (!std::isfinite(x_m) || std::abs(x_m) > 5)
    throw ConfigError("camera_x_m: must be within [-5, 5] [m]");
  if (!std::isfinite(y_m) || std::abs(y_m) > 5)
    throw ConfigError("camera_y_m: must be within [-5, 5] [m]");
}

cv::Matx33d CameraMount::cameraToRobot() const {
  const double c = std::cos(pitch_rad), s = std::sin(pitch_rad);
  // Columns: the optical x (right), y (down-ish), z (forward, tilted down) in the robot frame.
  return {0,  -s, c,  //
          -1, 0,  0,  //
          0,  -c, -s};
}

cv::Vec3d CameraMount::floorUpInCamera() const { return cameraToRobot().t() * cv::Vec3d(0, 0, 1); }

int floorRowLimitPx(const CameraMount& mount, double fy_px, double cy_px, int height_px,
                    double forward_m) {
  // A floor point forward_m ahead lies atan(h/d) below the horizon, i.e. atan(h/d) − pitch below
  // the optical axis: v = cy + fy·tan(that). Rows correspond to lines of constant depth.
  const double below_axis = std::atan2(mount.height_m, forward_m) - mount.pitch_rad;
  if (below_axis <= -M_PI / 2 + 1e-6) return 0;
  const double v = cy_px + fy_px * std::tan(below_axis);
  return std::clamp(static_cast<int>(std::floor(v)), 0, height_px);
}

TagSighting sightTag(const markers::TagDetection& detection, const CameraMount& mount) {
  const cv::Matx33d R_rc = mount.cameraToRobot();
  const cv::Matx33d R = R_rc * detection.rotation;  // tag axes in the robot frame
  // The tag's up is its −y axis; its z axis points into the floor.
  const cv::Vec3d up(-R(0, 1), -R(1, 1), -R(2, 1));
  const cv::Vec3d into(R(0, 2), R(1, 2), R(2, 2));
  TagSighting s;
  s.id = detection.id;
  s.heading_rad = -std::atan2(up[1], up[0]);
  s.tilt_rad = std::acos(std::clamp(-into[2], -1.0, 1.0));
  const cv::Vec3d p =
      R_rc * detection.translation_m + cv::Vec3d(mount.x_m, mount.y_m, mount.height_m);
  s.x_m = p[0];
  s.y_m = p[1];
  s.distance_m = cv::norm(detection.translation_m);
  return s;
}

void HeadingOptions::validate() const {
  if (!(max_tilt_rad > 0 && max_tilt_rad < M_PI / 2))
    throw ConfigError("max_tag_tilt_rad: must be within (0, pi/2)");
  if (!(outlier_rad > 0 && outlier_rad < M_PI))
    throw ConfigError("tag_outlier_rad: must be within (0, pi)");
  if (!(max_distance_m > 0)) throw ConfigError("max_tag_distance_m: must be > 0 [m]");
  if (!(prefer_distance_m > 0 && prefer_distance_m <= max_distance_m)) {
    throw ConfigError("prefer_tag_distance_m: must be within (0, max_tag_distance_m] [m]");
  }
}

double lateralOffsetM(const TagSighting& sighting, double heading_rad) {
  // The tags' up direction in the robot frame is at −heading; the robot is at the origin.
  return -std::cos(heading_rad) * sighting.y_m - std::sin(heading_rad) * sighting.x_m;
}

double measureLateralM(const std::vector<TagSighting>& sightings, const HeadingMeasurement& m,
                       const HeadingOptions& options) {
  if (!m.valid) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  int n = 0;
  for (const auto& s : sightings) {
    if (s.distance_m > options.max_distance_m) continue;
    if (std::abs(wrapAngle(s.heading_rad - m.heading_rad)) > options.outlier_rad) continue;
    sum += lateralOffsetM(s, m.heading_rad);
    ++n;
  }
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

HeadingMeasurement measureHeading(const std::vector<TagSighting>& sightings,
                                  const HeadingOptions& options) {
  HeadingMeasurement m;
  std::vector<double> headings;
  bool any_near = false;
  for (const TagSighting& s : sightings) {
    any_near =
        any_near || (s.tilt_rad <= options.max_tilt_rad &&
                     s.distance_m <= options.prefer_distance_m && std::isfinite(s.heading_rad));
  }
  m.near = any_near;
  const double max_distance = any_near ? options.prefer_distance_m : options.max_distance_m;
  for (const TagSighting& s : sightings) {
    if (s.tilt_rad > options.max_tilt_rad || s.distance_m > max_distance ||
        !std::isfinite(s.heading_rad)) {
      ++m.outliers;
    } else {
      headings.push_back(s.heading_rad);
    }
  }
  if (headings.empty()) return m;
  // Median on the circle: the heading with the smallest sum of absolute angular differences.
  double median = headings[0];
  double best = 1e300;
  for (double h : headings) {
    double sum = 0;
    for (double g : headings) sum += std::abs(wrapAngle(g - h));
    if (sum < best) {
      best = sum;
      median = h;
    }
  }
  double sum = 0, sum2 = 0;
  for (double h : headings) {
    const double d = wrapAngle(h - median);
    if (std::abs(d) > options.outlier_rad) {
      ++m.outliers;
      continue;
    }
    sum += d;
    sum2 += d * d;
    ++m.inliers;
  }
  const double mean = sum / m.inliers;
  m.valid = true;
  m.heading_rad = wrapAngle(median + mean);
  m.spread_rad = m.inliers > 1 ? std::sqrt(std::max(0.0, sum2 / m.inliers - mean * mean)) : 0.0;
  return m;
}

}  // namespace wheels
}  // namespace autocal
