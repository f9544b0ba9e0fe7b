#include "autocal/camera/pinhole_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace camera {

namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// The intrinsics [fx fy cx cy, distortion...] and the poses [rvec tvec] of every view.
struct Parameters {
  std::vector<double> intrinsics;
  std::vector<Vector6> poses;

  cv::Matx33d cameraMatrix() const {
    return cv::Matx33d(intrinsics[0], 0, intrinsics[2], 0, intrinsics[1], intrinsics[3], 0, 0, 1);
  }
  cv::Mat distortion() const {
    return cv::Mat(std::vector<double>(intrinsics.begin() + 4, intrinsics.end()), true);
  }
  double squaredNorm() const {
    double s = 0;
    for (double q : intrinsics) s += q * q;
    for (const Vector6& p : poses) s += p.squaredNorm();
    return s;
  }
};

cv::Mat column(const Vector6& pose, int first) {
  return (cv::Mat_<double>(3, 1) << pose[first], pose[first + 1], pose[first + 2]);
}

/// The normal equations at a set of parameters, with the poses' blocks kept apart: for the
/// intrinsics' free columns A and each view's pose columns B, U = sum A^T A, V_v = B^T B,
/// W_v = A^T B, and the gradients A^T r and B^T r of the residuals r = corner - projection.
struct Normal {
  Eigen::MatrixXd u;
  Eigen::VectorXd intrinsics_gradient;
  std::vector<Matrix6> v;
  std::vector<Eigen::MatrixXd> w;
  std::vector<Vector6> pose_gradient;
  double squared = 0;  ///< sum of the squared residuals
};

class Problem {
 public:
  Problem(const std::vector<std::vector<cv::Point3f>>& object_points,
          const std::vector<std::vector<cv::Point2f>>& image_points, std::vector<int> free)
      : object_(object_points), image_(image_points), free_(std::move(free)) {}

  int freeCount() const { return static_cast<int>(free_.size()); }

  /// The sum of the squared residuals (infinite when a projection is not finite).
  double squared(const Parameters& p) const {
    double s = 0;
    std::vector<cv::Point2f> projected;
    for (size_t v = 0; v < object_.size(); ++v) {
      cv::projectPoints(object_[v], column(p.poses[v], 0), column(p.poses[v], 3),
                        cv::Mat(p.cameraMatrix()), p.distortion(), projected);
      for (size_t i = 0; i < projected.size(); ++i) {
        const double dx = image_[v][i].x - projected[i].x, dy = image_[v][i].y - projected[i].y;
        s += dx * dx + dy * dy;
      }
    }
    return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
  }

  Normal normal(const Parameters& p) const {
    const int n_free = freeCount();
    Normal out;
    out.u = Eigen::MatrixXd::Zero(n_free, n_free);
    out.intrinsics_gradient = Eigen::VectorXd::Zero(n_free);
    std::vector<cv::Point2f> projected;
    cv::Mat jacobian;
    for (size_t v = 0; v < object_.size(); ++v) {
      cv::projectPoints(object_[v], column(p.poses[v], 0), column(p.poses[v], 3),
                        cv::Mat(p.cameraMatrix()), p.distortion(), projected, jacobian);
      const int rows = jacobian.rows;
      Eigen::MatrixXd a(rows, n_free);
      Eigen::Matrix<double, Eigen::Dynamic, 6> b(rows, 6);
      Eigen::VectorXd r(rows);
      for (int i = 0; i < rows; ++i) {
        const double* j = jacobian.ptr<double>(i);
        for (int c = 0; c < 6; ++c) b(i, c) = j[c];
        for (int c = 0; c < n_free; ++c) a(i, c) = j[6 + free_[static_cast<size_t>(c)]];
        const size_t corner = static_cast<size_t>(i / 2);
        r[i] = i % 2 == 0 ? image_[v][corner].x - projected[corner].x
                          : image_[v][corner].y - projected[corner].y;
      }
      out.u.noalias() += a.transpose() * a;
      out.intrinsics_gradient.noalias() += a.transpose() * r;
      out.v.push_back(b.transpose() * b);
      out.w.push_back(a.transpose() * b);
      out.pose_gradient.push_back(b.transpose() * r);
      out.squared += r.squaredNorm();
    }
    return out;
  }

  /// The Levenberg-Marquardt step at damping `lambda` (each diagonal entry times 1 + lambda, as
  /// OpenCV's solver damps): the intrinsics' step from the Schur complement of the poses, then
  /// each pose's step.
  bool step(const Normal& n, double lambda, Eigen::VectorXd* intrinsics,
            std::vector<Vector6>* poses) const {
    Eigen::MatrixXd s = n.u;
    s.diagonal() *= 1 + lambda;
    Eigen::VectorXd rhs = n.intrinsics_gradient;
    std::vector<Eigen::LDLT<Matrix6>> v_inverse;
    for (size_t k = 0; k < n.v.size(); ++k) {
      Matrix6 v = n.v[k];
      v.diagonal() *= 1 + lambda;
      v_inverse.emplace_back(v);
      if (v_inverse.back().info() != Eigen::Success) return false;
      s.noalias() -= n.w[k] * v_inverse.back().solve(n.w[k].transpose());
      rhs.noalias() -= n.w[k] * v_inverse.back().solve(n.pose_gradient[k]);
    }
    const Eigen::LDLT<Eigen::MatrixXd> solver(s);
    if (solver.info() != Eigen::Success) return false;
    *intrinsics = solver.solve(rhs);
    poses->clear();
    for (size_t k = 0; k < n.v.size(); ++k)
      poses->push_back(v_inverse[k].solve(n.pose_gradient[k] - n.w[k].transpose() * *intrinsics));
    return intrinsics->allFinite();
  }

  /// The intrinsics' block of the inverse of the whole normal matrix (the Schur complement's
  /// pseudo-inverse, as OpenCV inverts by SVD).
  Eigen::MatrixXd intrinsicsInverse(const Normal& n) const {
    Eigen::MatrixXd s = n.u;
    for (size_t k = 0; k < n.v.size(); ++k)
      s.noalias() -= n.w[k] * n.v[k].ldlt().solve(n.w[k].transpose());
    return s.completeOrthogonalDecomposition().pseudoInverse();
  }

  Parameters moved(const Parameters& p, const Eigen::VectorXd& intrinsics,
                   const std::vector<Vector6>& poses) const {
    Parameters q = p;
    for (int c = 0; c < freeCount(); ++c)
      q.intrinsics[static_cast<size_t>(free_[static_cast<size_t>(c)])] += intrinsics[c];
    for (size_t v = 0; v < q.poses.size(); ++v) q.poses[v] += poses[v];
    return q;
  }

 private:
  const std::vector<std::vector<cv::Point3f>>& object_;
  const std::vector<std::vector<cv::Point2f>>& image_;
  std::vector<int> free_;  ///< indices into Parameters::intrinsics
};

}  // namespace

PinholeFit fitPinhole(const std::vector<std::vector<cv::Point3f>>& object_points,
                      const std::vector<std::vector<cv::Point2f>>& image_points,
                      const cv::Size& image_size, cv::Mat& camera_matrix, cv::Mat& distortion,
                      std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs, int flags,
                      const cv::TermCriteria& criteria) {
  const int supported = cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_ZERO_TANGENT_DIST |
                        cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 |
                        cv::CALIB_FIX_K5 | cv::CALIB_FIX_K6 | cv::CALIB_RATIONAL_MODEL;
  if (flags & ~supported) CV_Error(cv::Error::StsBadFlag, "fitPinhole: unsupported flags");
  if (object_points.empty() || object_points.size() != image_points.size())
    CV_Error(cv::Error::StsBadArg, "fitPinhole: as many views of points as of corners needed");
  size_t corners = 0;
  for (size_t v = 0; v < object_points.size(); ++v) {
    if (object_points[v].size() != image_points[v].size() || object_points[v].size() < 4)
      CV_Error(cv::Error::StsBadArg, "fitPinhole: each view needs 4 or more matched points");
    corners += object_points[v].size();
  }
  const size_t terms = (flags & cv::CALIB_RATIONAL_MODEL) ? 8 : 5;
  Parameters p;
  p.intrinsics.assign(4 + terms, 0.0);
  cv::Matx33d k;
  if (flags & cv::CALIB_USE_INTRINSIC_GUESS) {
    cv::Mat km;
    camera_matrix.convertTo(km, CV_64F);
    k = cv::Matx33d(km);
    cv::Mat d;
    distortion.convertTo(d, CV_64F);
    d = d.reshape(1, 1);
    for (int i = 0; i < std::min(d.cols, static_cast<int>(terms)); ++i)
      p.intrinsics[4 + static_cast<size_t>(i)] = d.at<double>(i);
    if (!(k(0, 0) > 0 && k(1, 1) > 0 && k(0, 2) >= 0 && k(0, 2) < image_size.width &&
          k(1, 2) >= 0 && k(1, 2) < image_size.height))
      CV_Error(cv::Error::StsOutOfRange, "fitPinhole: the camera matrix to start from is invalid");
  } else {
    cv::Mat km;
    cv::initCameraMatrix2D(object_points, image_points, image_size, 0).convertTo(km, CV_64F);
    k = cv::Matx33d(km);
  }
  p.intrinsics[0] = k(0, 0), p.intrinsics[1] = k(1, 1);
  p.intrinsics[2] = k(0, 2), p.intrinsics[3] = k(1, 2);
  std::vector<bool> fixed(4 + terms, false);
  if (flags & cv::CALIB_ZERO_TANGENT_DIST) {
    p.intrinsics[6] = p.intrinsics[7] = 0;
    fixed[6] = fixed[7] = true;
  }
  const std::pair<int, size_t> fix_flags[] = {{cv::CALIB_FIX_K1, 4}, {cv::CALIB_FIX_K2, 5},
                                              {cv::CALIB_FIX_K3, 8}, {cv::CALIB_FIX_K4, 9},
                                              {cv::CALIB_FIX_K5, 10}, {cv::CALIB_FIX_K6, 11}};
  for (const auto& [flag, index] : fix_flags)
    if ((flags & flag) && index < fixed.size()) fixed[index] = true;
  std::vector<int> free;
  for (size_t i = 0; i < fixed.size(); ++i)
    if (!fixed[i]) free.push_back(static_cast<int>(i));

  // Each view placed with the starting model, as OpenCV starts its joint fit.
  for (size_t v = 0; v < object_points.size(); ++v) {
    cv::Mat rvec, tvec;
    cv::solvePnP(object_points[v], image_points[v], cv::Mat(p.cameraMatrix()), p.distortion(),
                 rvec, tvec);
    Vector6 pose;
    for (int i = 0; i < 3; ++i) pose[i] = rvec.at<double>(i), pose[3 + i] = tvec.at<double>(i);
    p.poses.push_back(pose);
  }

  const Problem problem(object_points, image_points, free);
  const int max_iterations =
      (criteria.type & cv::TermCriteria::COUNT) ? std::max(1, criteria.maxCount) : 30;
  const double epsilon = (criteria.type & cv::TermCriteria::EPS) ? criteria.epsilon : DBL_EPSILON;
  PinholeFit out;
  Normal normal = problem.normal(p);
  if (!std::isfinite(normal.squared))
    CV_Error(cv::Error::StsNoConv, "fitPinhole: the starting model projects no view");
  double lambda = 1e-3;
  Eigen::VectorXd intrinsics_step;
  std::vector<Vector6> pose_steps;
  while (out.iterations < max_iterations) {
    ++out.iterations;
    if (!problem.step(normal, lambda, &intrinsics_step, &pose_steps)) {
      lambda = std::min(lambda * 10, 1e16);
      continue;
    }
    const Parameters next = problem.moved(p, intrinsics_step, pose_steps);
    const double squared = problem.squared(next);
    if (!(squared <= normal.squared)) {
      lambda = std::min(lambda * 10, 1e16);
      if (lambda >= 1e16) break;
      continue;
    }
    double change = intrinsics_step.squaredNorm();
    for (const Vector6& s : pose_steps) change += s.squaredNorm();
    const double relative = std::sqrt(change / std::max(p.squaredNorm(), DBL_MIN));
    p = next;
    lambda = std::max(lambda / 10, 1e-16);
    normal = problem.normal(p);
    if (relative < epsilon) break;
  }

  const Eigen::MatrixXd inverse = problem.intrinsicsInverse(normal);
  const double degrees_of_freedom =
      static_cast<double>(corners) - static_cast<double>(free.size() + 6 * p.poses.size());
  // OpenCV 4.6's estimate of the noise: the squared residuals over the corners (not their
  // coordinates) less the free parameters.
  const double sigma2 = degrees_of_freedom > 0 ? normal.squared / degrees_of_freedom : 0;
  out.std_devs.assign(4 + terms, 0.0);
  for (size_t c = 0; c < free.size(); ++c) {
    const int i = static_cast<int>(c);
    out.std_devs[static_cast<size_t>(free[c])] = std::sqrt(std::max(0.0, inverse(i, i)) * sigma2);
  }
  out.rms_px = std::sqrt(normal.squared / static_cast<double>(corners));
  camera_matrix = cv::Mat(p.cameraMatrix(), true);
  distortion = p.distortion().reshape(1, 1);
  rvecs.clear();
  tvecs.clear();
  for (const Vector6& pose : p.poses) {
    rvecs.push_back(column(pose, 0));
    tvecs.push_back(column(pose, 3));
  }
  return out;
}

}  // namespace camera
}  // namespace autocal
