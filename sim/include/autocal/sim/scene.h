// The geometry of the simulated world as the camera and the tests see it: where a board's inner
// corners and a tag's corners truly are, and where the camera is for a robot pose.
// World frame: x, y on the floor, z up. Robot frame: x ahead, y left, z up, origin at the middle
// of the wheel axle on the floor. Camera frame (OpenCV): x right, y down, z along the optical axis.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "autocal/sim/config.h"

namespace autocal {
namespace sim {

/// Rotation taking camera-frame vectors to the robot frame for a camera pitched down by
/// `pitch_rad` (optical axis ahead, tilted towards the floor), then turned left by `yaw_rad` about
/// the robot's z axis, and by `roll_rad` about its optical axis (the image's right side down).
Eigen::Matrix3d cameraToRobotRotation(double pitch_rad, double yaw_rad = 0.0,
                                      double roll_rad = 0.0);
/// The same for a robot's camera mount.
Eigen::Matrix3d cameraToRobotRotation(const CameraConfig& camera);

/// Pose of the camera in the world (maps camera-frame points to world points).
Eigen::Isometry3d cameraInWorld(const CameraConfig& camera, const Pose2& robot);

/// Unit direction (on the floor plan) a board's printed side faces, and its "right" as seen by a
/// viewer in front of it.
Eigen::Vector2d boardNormal(const ChessboardConfig& board);
Eigen::Vector2d boardRight(const ChessboardConfig& board);
/// Board width and height including the white margin [m].
double boardWidth(const ChessboardConfig& board);
double boardHeight(const ChessboardConfig& board);

/// World coordinates of the board's inner corners, row by row from the top-left as seen from the
/// front (cols per row, rows rows).
std::vector<Eigen::Vector3d> chessboardCorners(const ChessboardConfig& board);

/// World coordinates of a floor tag's four outer black-border corners in libapriltag's order
/// (detection p[0..3]: the tag's own bottom-left, bottom-right, top-right, top-left).
std::array<Eigen::Vector3d, 4> tagCorners(const FloorTagConfig& tag);

/// The tag's frame as libapriltag's pose estimate defines it: x along the tag's image right,
/// y along its image down, z into the tag (here: into the floor); origin at the tag's centre.
Eigen::Isometry3d tagInWorld(const FloorTagConfig& tag);

}  // namespace sim
}  // namespace autocal
