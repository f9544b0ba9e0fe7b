// Duckietown's manual extrinsics procedure, done from one image: a chessboard lies on the floor in
// front of the robot at known offsets; the camera's pose on the robot comes from the board's
// corners, and the ground homography from that pose (see ground_projection.h).
//
// Duckietown fits a homography to the corners with RANSAC and checks only the sign of H[1][2].
// Here the corners are found in the rectified image (the camera_info's R and P, as Duckietown
// rectifies), the camera's pose (6 numbers, not a homography's 8) is fitted to them, the
// homography follows from the pose, and the result is refused when the corners lie off it on the
// floor or the pose is none a Duckiebot can have.
#pragma once

#include <string>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/extrinsics/ground_projection.h"

namespace autocal {
namespace extrinsics {

/// The board on the floor. Corner (r, c) (row r from the robot, column c from the robot's right)
/// is at x = offset_x_m + r·square_m, y = −offset_y_m + c·square_m in the robot frame (Duckietown's
/// ground_projection default.yaml: board_w 7, board_h 5, square_size 0.031, x_offset 0.191,
/// y_offset 0.093: the board centred on the robot's centre line).
struct FloorBoard {
  int cols = 7;  ///< inner corners across the robot's path
  int rows = 5;  ///< inner corners along it
  double square_m = 0.031;
  double offset_x_m = 0.191;  ///< the nearest corner row ahead of the axle
  double offset_y_m = 0.093;  ///< the rightmost corner column right of the centre line

  /// Throws ConfigError naming the bad value.
  void validate() const;
  /// The corners in the robot frame, row by row from the robot, each row from right to left.
  std::vector<Eigen::Vector2d> cornersOnFloor() const;
};

/// The camera poses a Duckiebot can have (any outside is a wrong board, wrong offsets, or a
/// bad detection).
struct MountLimits {
  double min_height_m = 0.03, max_height_m = 0.3;
  double min_pitch_rad = 0.0, max_pitch_rad = 1.2;
  double max_abs_roll_rad = 0.2;
  double max_abs_yaw_rad = 0.35;
  double min_x_m = -0.15, max_x_m = 0.25;
  double max_abs_y_m = 0.1;
};

struct FloorBoardOptions {
  FloorBoard board;
  MountLimits limits;
  /// The corners' RMS distance on the floor from where the fitted pose puts them, at most [m].
  double max_board_rms_m = 0.003;
};

/// A camera_info's rectified camera: P's left 3x3 and R.
struct CameraInfoRectification {
  CameraIntrinsics intrinsics;
  RectifiedCamera rectified;
};

struct FloorBoardResult {
  Eigen::Matrix3d homography = Eigen::Matrix3d::Identity();
  CameraMount mount;
  /// One standard deviation of each mount number, from the corners' scatter (the fit's
  /// covariance).
  CameraMount mount_sigma;
  double board_rms_m = 0, board_max_m = 0;  ///< the corners' floor residuals
  double reprojection_rms_px = 0;           ///< the corners' residuals in the rectified image
  std::vector<Eigen::Vector2d> corners_px;  ///< in the rectified image, in cornersOnFloor order
};

/// The rectified image of a raw one (the camera_info's K, D, R and P).
cv::Mat rectifyImage(const cv::Mat& raw, const CameraInfoRectification& camera);

/// The floor as a ground homography H sees it, for a person to check: a grid of lines every
/// step_m from x_near_m to x_far_m ahead of the axle and y_half_m to either side, and the robot's
/// centre line, drawn into a rectified BGR image (the lines where H puts them; green, the centre
/// line yellow).
struct FloorGrid {
  double x_near_m = 0.1, x_far_m = 0.6, y_half_m = 0.3, step_m = 0.05;
};
void drawFloorGrid(cv::Mat& rectified_bgr, const Eigen::Matrix3d& homography,
                   const FloorGrid& grid = {});

/// The camera's mount and ground homography from a raw image of the board. Throws
/// CalibrationError with the cause when the board is not found, its corners lie off the fitted
/// pose (max_board_rms_m), or the pose is outside the limits; ConfigError on bad options.
FloorBoardResult calibrateFromFloorBoard(const cv::Mat& raw_image,
                                         const CameraInfoRectification& camera,
                                         const FloorBoardOptions& options);

}  // namespace extrinsics
}  // namespace autocal
