#include "autocal/sim/scene.h"

#include <Eigen/Geometry>
#include <cmath>

namespace autocal {
namespace sim {

Eigen::Matrix3d cameraToRobotRotation(double pitch_rad, double yaw_rad, double roll_rad) {
  const double c = std::cos(pitch_rad), s = std::sin(pitch_rad);
  Eigen::Matrix3d R;
  // Columns: the camera's x (right), y (down) and z (optical axis) in the robot frame, tilted down
  // by the pitch; then turned about the robot's z by the yaw, and about the optical axis by the
  // roll.
  R.col(0) = Eigen::Vector3d(0, -1, 0);
  R.col(1) = Eigen::Vector3d(-s, 0, -c);
  R.col(2) = Eigen::Vector3d(c, 0, -s);
  return Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R *
         Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Matrix3d cameraToRobotRotation(const CameraConfig& camera) {
  return cameraToRobotRotation(camera.pitch_rad, camera.yaw_rad, camera.roll_rad);
}

Eigen::Isometry3d cameraInWorld(const CameraConfig& camera, const Pose2& robot) {
  const Eigen::Matrix3d world_robot =
      Eigen::AngleAxisd(robot.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = world_robot * cameraToRobotRotation(camera);
  T.translation() = Eigen::Vector3d(robot.x_m, robot.y_m, 0) +
                    world_robot * Eigen::Vector3d(camera.x_m, camera.y_m, camera.height_m);
  return T;
}

Eigen::Vector2d boardNormal(const ChessboardConfig& b) {
  return {std::cos(b.pose.yaw_rad), std::sin(b.pose.yaw_rad)};
}

Eigen::Vector2d boardRight(const ChessboardConfig& b) {
  // A viewer in front looks along -normal; their right is that direction turned clockwise.
  const Eigen::Vector2d n = boardNormal(b);
  return {n.y(), -n.x()};
}

double boardWidth(const ChessboardConfig& b) { return (b.cols + 1) * b.square_m + 2 * b.margin_m; }
double boardHeight(const ChessboardConfig& b) { return (b.rows + 1) * b.square_m + 2 * b.margin_m; }

std::vector<Eigen::Vector3d> chessboardCorners(const ChessboardConfig& b) {
  const Eigen::Vector2d right = boardRight(b);
  const Eigen::Vector2d centre(b.pose.x_m, b.pose.y_m);
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<size_t>(b.cols * b.rows));
  for (int r = 0; r < b.rows; ++r) {
    for (int c = 0; c < b.cols; ++c) {
      const double s = (c - 0.5 * (b.cols - 1)) * b.square_m;  // along right
      const double z = b.center_z_m + (0.5 * (b.rows - 1) - r) * b.square_m;
      const Eigen::Vector2d p = centre + s * right;
      out.emplace_back(p.x(), p.y(), z);
    }
  }
  return out;
}

Eigen::Isometry3d tagInWorld(const FloorTagConfig& tag) {
  const double c = std::cos(tag.pose.yaw_rad), s = std::sin(tag.pose.yaw_rad);
  // The tag's image right is x_t = (c, s); its image up is y_t = (-s, c) (seen from above), so
  // libapriltag's y (image down) is -y_t and its z (x cross y) points into the floor.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = Eigen::Vector3d(c, s, 0);
  T.linear().col(1) = Eigen::Vector3d(s, -c, 0);
  T.linear().col(2) = Eigen::Vector3d(0, 0, -1);
  T.translation() = Eigen::Vector3d(tag.pose.x_m, tag.pose.y_m, 0);
  return T;
}

std::array<Eigen::Vector3d, 4> tagCorners(const FloorTagConfig& tag) {
  const Eigen::Isometry3d T = tagInWorld(tag);
  const double h = 0.5 * tag.size_m;
  // libapriltag: p[0] = (-h, +h), p[1] = (+h, +h), p[2] = (+h, -h), p[3] = (-h, -h) in the tag
  // frame (x right, y down).
  return {T * Eigen::Vector3d(-h, h, 0), T * Eigen::Vector3d(h, h, 0),
          T * Eigen::Vector3d(h, -h, 0), T * Eigen::Vector3d(-h, -h, 0)};
}

}  // namespace sim
}  // namespace autocal
