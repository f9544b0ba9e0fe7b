// Duckietown's acceptance test of a wheel calibration, ROS-free: the robot drives a given distance
// straight ahead (Duckietown: 2 m along a tape) and the lateral offset from the line it started on
// is its drift (Duckietown accepts 10 cm). StraightTrack follows the poses of one such drive.
#pragma once

#include <vector>

#include "autocal/pose2d.h"

namespace autocal {
namespace wheels {

class StraightTrack {
 public:
  /// The line is the start pose's position and heading.
  explicit StraightTrack(const Pose2D& start);

  /// Adds the next pose of the drive (in the start pose's frame of reference).
  void add(const Pose2D& pose);

  /// Distance along the line of the last pose [m] (negative behind the start).
  double alongM() const { return along_m_; }
  /// Signed lateral offset of the last pose [m] (positive: to the left of the line).
  double lateralM() const { return lateral_m_; }
  /// The heading of the last pose relative to the line [rad], wrapped to (-π, π].
  double headingRad() const { return heading_rad_; }

  /// The signed lateral offset where the drive first reached `distance_m` along the line,
  /// interpolated between the two poses around it [m]; NaN when it has not got that far.
  double lateralAtM(double distance_m) const;

 private:
  Pose2D start_;
  double along_m_ = 0, lateral_m_ = 0, heading_rad_ = 0;
  std::vector<std::pair<double, double>> track_;  // along, lateral
};

}  // namespace wheels
}  // namespace autocal
