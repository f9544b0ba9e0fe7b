#include "autocal/sim/camera_model.h"

#include <Eigen/Dense>
#include <cmath>

#include "autocal/errors.h"

namespace autocal {
namespace sim {

CameraModel::CameraModel(const Intrinsics& intrinsics) : in_(intrinsics) {
  if (in_.distortion_coefficients.size() != distortionCoefficientCount(in_.distortion_model)) {
    throw ConfigError("camera model " + distortionModelName(in_.distortion_model) + " takes " +
                      std::to_string(distortionCoefficientCount(in_.distortion_model)) + " coefficients");
  }
  for (size_t i = 0; i < in_.distortion_coefficients.size(); ++i) k_[i] = in_.distortion_coefficients[i];
}

Eigen::Vector2d CameraModel::distort(const Eigen::Vector2d& p) const {
  const double x = p.x(), y = p.y();
  const double r2 = x * x + y * y;
  if (in_.distortion_model == DistortionModel::kEquidistant) {
    // OpenCV fisheye: theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8).
    const double r = std::sqrt(r2);
    if (r < 1e-15) return p;
    const double th = std::atan(r), th2 = th * th;
    const double thd = th * (1 + th2 * (k_[0] + th2 * (k_[1] + th2 * (k_[2] + th2 * k_[3]))));
    return p * (thd / r);
  }
  // plumb_bob: k1 k2 p1 p2 k3; rational_polynomial: k1 k2 p1 p2 k3 k4 k5 k6.
  const double k1 = k_[0], k2 = k_[1], p1 = k_[2], p2 = k_[3], k3 = k_[4];
  const double k4 = k_[5], k5 = k_[6], k6 = k_[7];
  const double radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
          y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

bool CameraModel::project(const Eigen::Vector3d& pc, Eigen::Vector2d* pixel) const {
  Eigen::Vector2d d;
  if (in_.distortion_model == DistortionModel::kEquidistant) {
    // The fisheye model also images points beside or behind the optical centre's plane.
    const double r = std::hypot(pc.x(), pc.y());
    if (r < 1e-15) {
      if (pc.z() <= 0) return false;
      d.setZero();
    } else {
      const double th = std::atan2(r, pc.z()), th2 = th * th;
      const double thd = th * (1 + th2 * (k_[0] + th2 * (k_[1] + th2 * (k_[2] + th2 * k_[3]))));
      d = Eigen::Vector2d(pc.x(), pc.y()) * (thd / r);
    }
  } else {
    if (pc.z() <= 1e-12) return false;
    d = distort(Eigen::Vector2d(pc.x() / pc.z(), pc.y() / pc.z()));
  }
  *pixel = Eigen::Vector2d(in_.fx * d.x() + in_.cx, in_.fy * d.y() + in_.cy);
  return true;
}

bool CameraModel::ray(double u, double v, Eigen::Vector3d* ray_cam) const {
  const Eigen::Vector2d target((u - in_.cx) / in_.fx, (v - in_.cy) / in_.fy);
  if (in_.distortion_model == DistortionModel::kEquidistant) {
    const double thd = target.norm();
    if (thd < 1e-15) {
      *ray_cam = Eigen::Vector3d(0, 0, 1);
      return true;
    }
    // Solve theta (1 + k1 theta^2 + ...) = theta_d for theta in [0, pi).
    double th = thd;
    for (int i = 0; i < 60; ++i) {
      const double t2 = th * th;
      const double f = th * (1 + t2 * (k_[0] + t2 * (k_[1] + t2 * (k_[2] + t2 * k_[3])))) - thd;
      const double df = 1 + t2 * (3 * k_[0] + t2 * (5 * k_[1] + t2 * (7 * k_[2] + t2 * 9 * k_[3])));
      if (df <= 1e-9) return false;
      const double step = f / df;
      th -= step;
      if (std::abs(step) < 1e-14) break;
    }
    if (!(th >= 0 && th < M_PI)) return false;
    const Eigen::Vector2d dir = target / thd;
    *ray_cam = Eigen::Vector3d(std::sin(th) * dir.x(), std::sin(th) * dir.y(), std::cos(th));
    return std::abs(std::atan2(std::hypot(ray_cam->x(), ray_cam->y()), ray_cam->z()) - th) < 1e-6;
  }
  // Newton's method on distort(p) = target with a numerical Jacobian; start at the target.
  Eigen::Vector2d p = target;
  bool converged = false;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d f = distort(p) - target;
    if (f.norm() < 1e-13) {
      converged = true;
      break;
    }
    const double h = 1e-7;
    Eigen::Matrix2d J;
    J.col(0) = (distort(p + Eigen::Vector2d(h, 0)) - distort(p - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (distort(p + Eigen::Vector2d(0, h)) - distort(p - Eigen::Vector2d(0, h))) / (2 * h);
    if (std::abs(J.determinant()) < 1e-12) return false;
    Eigen::Vector2d step = J.inverse() * f;
    // Damp steps that would jump far: the radial polynomial can fold back far from the image.
    const double max_step = 0.5 * (1.0 + p.norm());
    if (step.norm() > max_step) step *= max_step / step.norm();
    p -= step;
  }
  if (!converged) return false;
  // Reject a solution on the folded branch of the polynomial (where the mapping turns back).
  const double h = 1e-6;
  Eigen::Matrix2d J;
  J.col(0) = (distort(p + Eigen::Vector2d(h, 0)) - distort(p - Eigen::Vector2d(h, 0))) / (2 * h);
  J.col(1) = (distort(p + Eigen::Vector2d(0, h)) - distort(p - Eigen::Vector2d(0, h))) / (2 * h);
  if (J.determinant() <= 0) return false;
  *ray_cam = Eigen::Vector3d(p.x(), p.y(), 1.0).normalized();
  return true;
}

}  // namespace sim
}  // namespace autocal
