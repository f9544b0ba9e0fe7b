// The true camera of the simulator: pinhole intrinsics with plumb_bob, rational_polynomial or
// equidistant (fisheye) distortion, in the conventions of OpenCV and ROS camera_info, so that a
// point projected here lands exactly where cv::projectPoints / cv::fisheye::projectPoints put it.
#pragma once

#include <Eigen/Core>

#include "autocal/sim/config.h"

namespace autocal {
namespace sim {

class CameraModel {
 public:
  explicit CameraModel(const Intrinsics& intrinsics);

  const Intrinsics& intrinsics() const { return in_; }

  /// Pixel of a point in the camera frame (x right, y down, z forward). False when the point is
  /// behind the camera (z <= 0 for the pinhole models).
  bool project(const Eigen::Vector3d& p_cam, Eigen::Vector2d* pixel) const;

  /// Distorted normalised coordinates of the undistorted ones (x/z, y/z).
  Eigen::Vector2d distort(const Eigen::Vector2d& undistorted) const;

  /// Unit ray in the camera frame that lands on pixel (u, v): the distortion is inverted by
  /// Newton's method to 1e-12. False where the model cannot be inverted (outside its domain).
  bool ray(double u, double v, Eigen::Vector3d* ray_cam) const;

 private:
  Intrinsics in_;
  double k_[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // coefficients, zero-padded
};

}  // namespace sim
}  // namespace autocal
