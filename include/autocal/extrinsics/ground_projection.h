// The camera's ground projection (Duckietown's camera extrinsics): where the camera sits on the
// robot, and the homography that takes a pixel of the RECTIFIED image to the floor point it sees.
//
// Frames (doc/files.md "camera_extrinsic"):
// - robot: x forward, y left, z up; origin on the floor below the middle of the wheel axle;
// - camera: OpenCV's (x right, y down, z along the optical axis);
// - rectified image: a camera point p is at pixel ~ P·R·p, with the camera_info's projection
//   matrix P (its left 3x3; monocular, so its fourth column is zero) and rectification matrix R
//   (the identity for a monocular camera), as image_geometry.PinholeCameraModel.rectifyPoint has
//   it.
//
// The homography H is dt-core's GroundProjectionGeometry.pixel2ground: [x, y, w] = H·[u, v, 1],
// the floor point (x/w, y/w) in the robot frame [m].
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace autocal {
namespace extrinsics {

/// The camera's pose on the robot. Its rotation is Rz(yaw)·R0(pitch)·Rz(roll): R0 looks along the
/// robot's x axis tilted down by pitch (image right = the robot's right), yaw then turns it about
/// the robot's z axis (positive: to the left), roll about the optical axis (positive: the image's
/// right side turns down).
struct CameraMount {
  double height_m = 0.1;   ///< optical centre above the floor
  double pitch_rad = 0.3;  ///< downward tilt of the optical axis
  double roll_rad = 0.0;
  double yaw_rad = 0.0;
  double x_m = 0.06;  ///< optical centre ahead of the axle
  double y_m = 0.0;   ///< optical centre left of the robot's centre line
};

/// The camera's axes (columns: x, y, z of the camera) in the robot frame.
Eigen::Matrix3d cameraToRobot(const CameraMount& mount);

/// The rectified image of a camera: the left 3x3 of its projection matrix P, and its
/// rectification matrix R.
struct RectifiedCamera {
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
};

/// H (pixel → floor) of a mount seen through `camera`, scaled so that H(2,2) = 1 when it is not
/// near 0. Throws CalibrationError when the floor plane passes through the optical centre.
Eigen::Matrix3d homographyFromMount(const CameraMount& mount, const RectifiedCamera& camera);

/// The mount whose homography through `camera` is H (any scale): the inverse of
/// homographyFromMount, its rotation the nearest to what H says. Throws CalibrationError when H
/// is singular or puts the camera below the floor.
CameraMount mountFromHomography(const Eigen::Matrix3d& H, const RectifiedCamera& camera);

/// The floor point (robot frame, metres) of a rectified pixel: dt-core's pixel2ground (a pixel
/// above the horizon gets the point behind the camera its ray's line meets, as there).
Eigen::Vector2d pixelToGround(const Eigen::Matrix3d& H, const Eigen::Vector2d& pixel);

/// The rectified pixel of a floor point (robot frame, metres): dt-core's ground2pixel.
Eigen::Vector2d groundToPixel(const Eigen::Matrix3d& H, const Eigen::Vector2d& ground_m);

}  // namespace extrinsics
}  // namespace autocal
