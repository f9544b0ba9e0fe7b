// The robot's heading relative to the floor tags (paper 000 §3.3–3.4): the rotation about the
// floor normal between the robot's forward axis and a tag's "up" (the direction in which the tag
// reads upright), from the tag's pose in the camera's optical frame and the camera mount. Not a
// raw Euler angle of the optical frame: the camera is pitched, so the tag's yaw in the optical
// frame mixes heading with the pitch. All tags of a field point the same way, so any tag in view
// measures the same heading; one read at a different orientation is an outlier.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "autocal/markers/tag_detection.h"

namespace autocal {
namespace wheels {

/// Where the camera sits on the robot. Robot frame: x ahead, y left, z up, origin at the middle of
/// the wheel axle on the floor. Defaults: a Duckiebot DB21's nominal mount.
struct CameraMount {
  double height_m = 0.105;  ///< optical centre above the floor [m]
  double pitch_rad = 0.26;  ///< downward tilt of the optical axis [rad]
  double x_m = 0.055;       ///< optical centre ahead of the wheel axle [m]
  double y_m = 0.0;         ///< optical centre left of the centre line [m]

  /// Throws ConfigError naming the first bad key.
  void validate() const;
  /// Rotation taking optical-frame vectors (x right, y down, z forward) to the robot frame.
  cv::Matx33d cameraToRobot() const;
  /// The floor's upward unit normal in the optical frame.
  cv::Vec3d floorUpInCamera() const;
};

/// The first row of the undistorted (pinhole) image that can show floor within `forward_m` ahead
/// of the camera [px]: floor farther away (and everything above the horizon) lies above it. 0 when
/// the whole image can (a camera looking up); the image height when none can.
int floorRowLimitPx(const CameraMount& mount, double fy_px, double cy_px, int height_px,
                    double forward_m);

/// One tag as the robot sees it.
struct TagSighting {
  int id = -1;
  double heading_rad = 0;   ///< robot's forward axis relative to the tag's up, counter-clockwise
  double x_m = 0, y_m = 0;  ///< tag centre in the robot frame [m]
  double tilt_rad = 0;      ///< angle between the tag's plane normal and the floor normal [rad]
  double distance_m = 0;    ///< camera to tag centre [m]
};

TagSighting sightTag(const markers::TagDetection& detection, const CameraMount& mount);

struct HeadingOptions {
  /// A tag whose plane is tilted from the floor by more than this is not a floor tag (or a bad
  /// pose) [rad].
  double max_tilt_rad = 0.25;
  /// A tag whose heading differs from the median of the frame's tags by more than this is an
  /// outlier (a tag laid at another orientation, a mis-detection) [rad].
  double outlier_rad = 0.09;
  /// Tags farther than this from the camera are not used (small, foreshortened: poor pose) [m].
  double max_distance_m = 0.6;
  /// When a tag nearer than this is in view, only such tags are used [m]: a 6.5 cm tag's heading is
  /// within 0.1° of the truth up to 0.3 m and biased by up to 1° at 0.5 m (simulator, 640x480).
  double prefer_distance_m = 0.3;

  void validate() const;
};

/// The heading from all the tags of one or more frames.
struct HeadingMeasurement {
  bool valid = false;      ///< at least one inlier tag
  double heading_rad = 0;  ///< mean of the inliers' headings
  double spread_rad = 0;   ///< standard deviation of the inliers' headings (0 for one)
  int inliers = 0;
  int outliers = 0;   ///< rejected: tilted, too far or off the median
  bool near = false;  ///< only tags within prefer_distance_m were used
};

/// Median, reject the outliers, average the rest (angles near each other: no wrap issue within
/// outlier_rad; the median is taken on the circle).
HeadingMeasurement measureHeading(const std::vector<TagSighting>& sightings,
                                  const HeadingOptions& options);

/// The robot's signed distance to the line through a tag along the tags' up direction [m], > 0
/// when the robot is left of it, from the tag's centre in the robot frame and the heading.
double lateralOffsetM(const TagSighting& sighting, double heading_rad);

/// The mean lateral offset (lateralOffsetM) of the sightings that agree with the frame's heading
/// `m` (within max_distance_m and outlier_rad of it) [m]; NaN when none does.
double measureLateralM(const std::vector<TagSighting>& sightings, const HeadingMeasurement& m,
                       const HeadingOptions& options);

/// Wraps to (−π, π].
double wrapAngle(double a_rad);

}  // namespace wheels
}  // namespace autocal
