// The camera mount and its ground homography (see ground_projection.h).
#include "autocal/extrinsics/ground_projection.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

#include "autocal/errors.h"

namespace autocal {
namespace extrinsics {

namespace {

Eigen::Matrix3d aboutZ(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

/// R0(pitch): the camera looking along the robot's x axis, tilted down by pitch.
Eigen::Matrix3d levelCamera(double pitch_rad) {
  const double c = std::cos(pitch_rad), s = std::sin(pitch_rad);
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0, -1, 0);   // image right: the robot's right
  r.col(1) = Eigen::Vector3d(-s, 0, -c);  // image down
  r.col(2) = Eigen::Vector3d(c, 0, -s);   // the optical axis
  return r;
}

Eigen::Vector3d position(const CameraMount& m) { return {m.x_m, m.y_m, m.height_m}; }

}  // namespace

Eigen::Matrix3d cameraToRobot(const CameraMount& m) {
  return aboutZ(m.yaw_rad) * levelCamera(m.pitch_rad) * aboutZ(m.roll_rad);
}

Eigen::Matrix3d homographyFromMount(const CameraMount& mount, const RectifiedCamera& camera) {
  // A floor point g = (x, y, 0) is at p = Rᵀ(g − t) in the camera, at pixel ~ P·Rrect·p:
  // G = P·Rrect·Rᵀ·[e1 e2 −t] takes (x, y, 1) to the pixel; H = G⁻¹.
  const Eigen::Matrix3d to_camera = cameraToRobot(mount).transpose();
  Eigen::Matrix3d plane;
  plane.col(0) = Eigen::Vector3d::UnitX();
  plane.col(1) = Eigen::Vector3d::UnitY();
  plane.col(2) = -position(mount);
  const Eigen::Matrix3d G = camera.P * camera.R * to_camera * plane;
  Eigen::FullPivLU<Eigen::Matrix3d> lu(G);
  if (!lu.isInvertible())
    throw CalibrationError("the floor plane passes through the camera: no ground homography");
  Eigen::Matrix3d H = lu.inverse();
  if (std::abs(H(2, 2)) > 1e-12 * H.norm()) H /= H(2, 2);
  return H;
}

CameraMount mountFromHomography(const Eigen::Matrix3d& H, const RectifiedCamera& camera) {
  Eigen::FullPivLU<Eigen::Matrix3d> lu(H);
  if (!lu.isInvertible()) throw CalibrationError("the ground homography is singular");
  // M = Rrectᵀ·P⁻¹·H⁻¹ = λ·[r1 r2 −Rᵀt], r1 and r2 the robot's x and y axes in the camera.
  const Eigen::Matrix3d M = camera.R.transpose() * camera.P.inverse() * lu.inverse();
  double lambda = 2.0 / (M.col(0).norm() + M.col(1).norm());
  Eigen::Matrix3d to_camera;
  to_camera.col(0) = lambda * M.col(0);
  to_camera.col(1) = lambda * M.col(1);
  to_camera.col(2) = to_camera.col(0).cross(to_camera.col(1));
  // The nearest rotation (the two columns of a measured H are not exactly orthonormal).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(to_camera, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rotation = svd.matrixU() * svd.matrixV().transpose();
  Eigen::Matrix3d to_robot = rotation.transpose();
  Eigen::Vector3d t = -to_robot * (lambda * M.col(2));
  if (t.z() < 0) {
    // The other sign of λ: the camera mirrored below the floor; turn it about the robot's z.
    lambda = -lambda;
    to_camera.col(0) = lambda * M.col(0);
    to_camera.col(1) = lambda * M.col(1);
    to_camera.col(2) = to_camera.col(0).cross(to_camera.col(1));
    Eigen::JacobiSVD<Eigen::Matrix3d> svd2(to_camera, Eigen::ComputeFullU | Eigen::ComputeFullV);
    rotation = svd2.matrixU() * svd2.matrixV().transpose();
    to_robot = rotation.transpose();
    t = -to_robot * (lambda * M.col(2));
  }
  if (!(t.z() > 0)) throw CalibrationError("the ground homography puts the camera on the floor");
  CameraMount m;
  m.x_m = t.x();
  m.y_m = t.y();
  m.height_m = t.z();
  // The optical axis Rz(yaw)·(cos pitch, 0, −sin pitch) gives pitch and yaw; the camera's x axis
  // in the yawed and pitched level frame gives roll.
  const Eigen::Vector3d z = to_robot.col(2);
  m.pitch_rad = std::asin(std::clamp(-z.z(), -1.0, 1.0));
  m.yaw_rad = std::atan2(z.y(), z.x());
  const Eigen::Vector3d x =
      (aboutZ(m.yaw_rad) * levelCamera(m.pitch_rad)).transpose() * to_robot.col(0);
  m.roll_rad = std::atan2(x.y(), x.x());
  return m;
}

Eigen::Vector2d pixelToGround(const Eigen::Matrix3d& H, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d g = H * pixel.homogeneous();
  return g.hnormalized();
}

Eigen::Vector2d groundToPixel(const Eigen::Matrix3d& H, const Eigen::Vector2d& ground_m) {
  const Eigen::Vector3d p = H.inverse() * ground_m.homogeneous();
  return p.hnormalized();
}

}  // namespace extrinsics
}  // namespace autocal
