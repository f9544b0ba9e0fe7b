#include "autocal/camera/joint_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace camera {

namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
// A step under at most this damping that changes the parameters by less than the criteria's
// epsilon ends the fit.
constexpr double kConvergedLambda = 1e-2;
using Vector6 = Eigen::Matrix<double, 6, 1>;
using Points3 = std::vector<cv::Point3d>;
using Points2 = std::vector<cv::Point2d>;

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

/// A view's points projected with `p`, and where `jacobian` is given, the Jacobian with columns
/// [rvec tvec, fx fy cx cy, distortion...].
void project(bool fisheye, const Points3& points, const Parameters& p, const Vector6& pose,
             Points2* projected, cv::Mat* jacobian) {
  const cv::Mat k(p.cameraMatrix()), rvec = column(pose, 0), tvec = column(pose, 3);
  if (!fisheye) {
    if (jacobian)
      cv::projectPoints(points, rvec, tvec, k, p.distortion(), *projected, *jacobian);
    else
      cv::projectPoints(points, rvec, tvec, k, p.distortion(), *projected);
    return;
  }
  if (!jacobian) {
    cv::fisheye::projectPoints(points, *projected, rvec, tvec, k, p.distortion());
    return;
  }
  // cv::fisheye's columns: f (2), c (2), k1..k4, rvec (3), tvec (3), skew.
  cv::Mat j;
  cv::fisheye::projectPoints(points, *projected, rvec, tvec, k, p.distortion(), 0, j);
  cv::hconcat(std::vector<cv::Mat>{j.colRange(8, 14), j.colRange(0, 8)}, *jacobian);
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
  Problem(bool fisheye, const std::vector<Points3>& object_points,
          const std::vector<Points2>& image_points, std::vector<int> free)
      : fisheye_(fisheye), object_(object_points), image_(image_points), free_(std::move(free)) {}

  int freeCount() const { return static_cast<int>(free_.size()); }
  const std::vector<int>& free() const { return free_; }

  /// The sum of the squared residuals (infinite when a projection is not finite).
  double squared(const Parameters& p) const {
    double s = 0;
    Points2 projected;
    for (size_t v = 0; v < object_.size(); ++v) {
      project(fisheye_, object_[v], p, p.poses[v], &projected, nullptr);
      for (size_t i = 0; i < projected.size(); ++i) {
        const cv::Point2d d = image_[v][i] - projected[i];
        s += d.x * d.x + d.y * d.y;
      }
    }
    return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
  }

  Normal normal(const Parameters& p) const {
    const int n_free = freeCount();
    Normal out;
    out.u = Eigen::MatrixXd::Zero(n_free, n_free);
    out.intrinsics_gradient = Eigen::VectorXd::Zero(n_free);
    Points2 projected;
    cv::Mat jacobian;
    for (size_t v = 0; v < object_.size(); ++v) {
      project(fisheye_, object_[v], p, p.poses[v], &projected, &jacobian);
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
    if (!std::isfinite(out.squared)) out.squared = std::numeric_limits<double>::infinity();
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
  bool fisheye_;
  const std::vector<Points3>& object_;
  const std::vector<Points2>& image_;
  std::vector<int> free_;  ///< indices into Parameters::intrinsics
};

size_t checkViews(const std::vector<Points3>& object_points,
                  const std::vector<Points2>& image_points) {
  if (object_points.empty() || object_points.size() != image_points.size())
    CV_Error(cv::Error::StsBadArg, "joint fit: as many views of points as of corners needed");
  size_t corners = 0;
  for (size_t v = 0; v < object_points.size(); ++v) {
    if (object_points[v].size() != image_points[v].size() || object_points[v].size() < 4)
      CV_Error(cv::Error::StsBadArg, "joint fit: each view needs 4 or more matched points");
    corners += object_points[v].size();
  }
  return corners;
}

/// The start's camera matrix and distortion from the caller's (the guess).
void readGuess(const cv::Mat& camera_matrix, const cv::Mat& distortion, Parameters* p) {
  cv::Mat k, d;
  camera_matrix.convertTo(k, CV_64F);
  distortion.convertTo(d, CV_64F);
  if (k.rows != 3 || k.cols != 3)
    CV_Error(cv::Error::StsBadArg, "joint fit: the camera matrix to start from is not 3x3");
  p->intrinsics[0] = k.at<double>(0, 0), p->intrinsics[1] = k.at<double>(1, 1);
  p->intrinsics[2] = k.at<double>(0, 2), p->intrinsics[3] = k.at<double>(1, 2);
  d = d.reshape(1, 1);
  for (int i = 0; i < std::min(d.cols, static_cast<int>(p->intrinsics.size()) - 4); ++i)
    p->intrinsics[4 + static_cast<size_t>(i)] = d.at<double>(i);
}

/// Levenberg-Marquardt from `p` (OpenCV's damping schedule and stopping rule: the relative
/// change of every parameter), then the outputs.
JointFit solve(const Problem& problem, Parameters p, size_t corners,
               const cv::TermCriteria& criteria, bool std_devs, cv::Mat& camera_matrix,
               cv::Mat& distortion, std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs) {
  const int max_iterations =
      (criteria.type & cv::TermCriteria::COUNT) ? std::max(1, criteria.maxCount) : 30;
  const double epsilon = (criteria.type & cv::TermCriteria::EPS) ? criteria.epsilon : DBL_EPSILON;
  JointFit out;
  Normal normal = problem.normal(p);
  if (!std::isfinite(normal.squared))
    CV_Error(cv::Error::StsNoConv, "joint fit: the starting model projects a view nowhere");
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
      if (lambda >= 1e16) break;
      lambda = std::min(lambda * 10, 1e16);
      continue;
    }
    double change = intrinsics_step.squaredNorm();
    for (const Vector6& s : pose_steps) change += s.squaredNorm();
    const double relative = std::sqrt(change / std::max(p.squaredNorm(), DBL_MIN));
    p = next;
    // A small step taken under heavy damping is not convergence: the damping shrinks it.
    const bool converged = relative < epsilon && lambda <= kConvergedLambda;
    lambda = std::max(lambda / 10, 1e-16);
    normal = problem.normal(p);
    if (converged) break;
  }
  if (std_devs) {
    const Eigen::MatrixXd inverse = problem.intrinsicsInverse(normal);
    const std::vector<int>& free = problem.free();
    const double degrees_of_freedom =
        static_cast<double>(corners) - static_cast<double>(free.size() + 6 * p.poses.size());
    // OpenCV 4.6's estimate of the noise: the squared residuals over the corners (not their
    // coordinates) less the free parameters.
    const double sigma2 = degrees_of_freedom > 0 ? normal.squared / degrees_of_freedom : 0;
    out.std_devs.assign(p.intrinsics.size(), 0.0);
    for (size_t c = 0; c < free.size(); ++c) {
      const int i = static_cast<int>(c);
      out.std_devs[static_cast<size_t>(free[c])] = std::sqrt(std::max(0.0, inverse(i, i)) * sigma2);
    }
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

std::vector<int> freeIndices(const std::vector<bool>& fixed) {
  std::vector<int> free;
  for (size_t i = 0; i < fixed.size(); ++i)
    if (!fixed[i]) free.push_back(static_cast<int>(i));
  return free;
}

}  // namespace

JointFit fitPinhole(const std::vector<std::vector<cv::Point3f>>& object_points,
                    const std::vector<std::vector<cv::Point2f>>& image_points,
                    const cv::Size& image_size, cv::Mat& camera_matrix, cv::Mat& distortion,
                    std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs, int flags,
                    const cv::TermCriteria& criteria) {
  const int supported = cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_ZERO_TANGENT_DIST |
                        cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 |
                        cv::CALIB_FIX_K5 | cv::CALIB_FIX_K6 | cv::CALIB_RATIONAL_MODEL;
  if (flags & ~supported) CV_Error(cv::Error::StsBadFlag, "fitPinhole: unsupported flags");
  std::vector<Points3> object;
  std::vector<Points2> image;
  for (const auto& v : object_points) object.emplace_back(v.begin(), v.end());
  for (const auto& v : image_points) image.emplace_back(v.begin(), v.end());
  const size_t corners = checkViews(object, image);
  const size_t terms = (flags & cv::CALIB_RATIONAL_MODEL) ? 8 : 5;
  Parameters p;
  p.intrinsics.assign(4 + terms, 0.0);
  if (flags & cv::CALIB_USE_INTRINSIC_GUESS) {
    readGuess(camera_matrix, distortion, &p);
    if (!(p.intrinsics[0] > 0 && p.intrinsics[1] > 0 && p.intrinsics[2] >= 0 &&
          p.intrinsics[2] < image_size.width && p.intrinsics[3] >= 0 &&
          p.intrinsics[3] < image_size.height))
      CV_Error(cv::Error::StsOutOfRange, "fitPinhole: the camera matrix to start from is invalid");
  } else {
    cv::Mat k;
    cv::initCameraMatrix2D(object_points, image_points, image_size, 0).convertTo(k, CV_64F);
    p.intrinsics[0] = k.at<double>(0, 0), p.intrinsics[1] = k.at<double>(1, 1);
    p.intrinsics[2] = k.at<double>(0, 2), p.intrinsics[3] = k.at<double>(1, 2);
  }
  std::vector<bool> fixed(4 + terms, false);
  if (flags & cv::CALIB_ZERO_TANGENT_DIST) {
    p.intrinsics[6] = p.intrinsics[7] = 0;
    fixed[6] = fixed[7] = true;
  }
  const std::pair<int, size_t> fix_flags[] = {{cv::CALIB_FIX_K1, 4},  {cv::CALIB_FIX_K2, 5},
                                              {cv::CALIB_FIX_K3, 8},  {cv::CALIB_FIX_K4, 9},
                                              {cv::CALIB_FIX_K5, 10}, {cv::CALIB_FIX_K6, 11}};
  for (const auto& [flag, index] : fix_flags)
    if ((flags & flag) && index < fixed.size()) fixed[index] = true;
  // Each view placed with the starting model, as OpenCV starts its joint fit.
  for (size_t v = 0; v < object.size(); ++v) {
    cv::Mat rvec, tvec;
    cv::solvePnP(object[v], image[v], cv::Mat(p.cameraMatrix()), p.distortion(), rvec, tvec);
    Vector6 pose;
    for (int i = 0; i < 3; ++i) pose[i] = rvec.at<double>(i), pose[3 + i] = tvec.at<double>(i);
    p.poses.push_back(pose);
  }
  const Problem problem(false, object, image, freeIndices(fixed));
  return solve(problem, std::move(p), corners, criteria, true, camera_matrix, distortion, rvecs,
               tvecs);
}

JointFit fitEquidistant(const std::vector<std::vector<cv::Point3d>>& object_points,
                        const std::vector<std::vector<cv::Point2d>>& image_points,
                        const cv::Size& image_size, cv::Mat& camera_matrix, cv::Mat& distortion,
                        std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs, int flags,
                        const cv::TermCriteria& criteria) {
  namespace fe = cv::fisheye;
  const int supported = fe::CALIB_USE_INTRINSIC_GUESS | fe::CALIB_RECOMPUTE_EXTRINSIC |
                        fe::CALIB_FIX_SKEW | fe::CALIB_FIX_K1 | fe::CALIB_FIX_K2 |
                        fe::CALIB_FIX_K3 | fe::CALIB_FIX_K4;
  if (flags & ~supported) CV_Error(cv::Error::StsBadFlag, "fitEquidistant: unsupported flags");
  const size_t corners = checkViews(object_points, image_points);
  Parameters p;
  p.intrinsics.assign(8, 0.0);
  if (flags & fe::CALIB_USE_INTRINSIC_GUESS) {
    readGuess(camera_matrix, distortion, &p);
  } else {
    const double f = std::max(image_size.width, image_size.height) / CV_PI;
    p.intrinsics[0] = p.intrinsics[1] = f;
    p.intrinsics[2] = image_size.width / 2.0 - 0.5;
    p.intrinsics[3] = image_size.height / 2.0 - 0.5;
  }
  if (!(p.intrinsics[0] > 0 && p.intrinsics[1] > 0))
    CV_Error(cv::Error::StsOutOfRange, "fitEquidistant: the focal length to start from is not > 0");
  std::vector<bool> fixed(8, false);
  const std::pair<int, size_t> fix_flags[] = {
      {fe::CALIB_FIX_K1, 4}, {fe::CALIB_FIX_K2, 5}, {fe::CALIB_FIX_K3, 6}, {fe::CALIB_FIX_K4, 7}};
  for (const auto& [flag, index] : fix_flags)
    if (flags & flag) fixed[index] = true;
  // Each view placed with the starting model: its corners' rays, then the pose of the board
  // that a pinhole camera sees along them.
  for (size_t v = 0; v < object_points.size(); ++v) {
    Points2 rays;
    fe::undistortPoints(image_points[v], rays, cv::Mat(p.cameraMatrix()), p.distortion());
    for (const cv::Point2d& r : rays)
      if (!std::isfinite(r.x) || !std::isfinite(r.y))
        CV_Error(cv::Error::StsNoConv, "fitEquidistant: the start maps no ray to a corner");
    cv::Mat rvec, tvec;
    cv::solvePnP(object_points[v], rays, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec);
    Vector6 pose;
    for (int i = 0; i < 3; ++i) pose[i] = rvec.at<double>(i), pose[3 + i] = tvec.at<double>(i);
    if (!pose.allFinite() || !(pose[5] > 0))
      CV_Error(cv::Error::StsNoConv, "fitEquidistant: the start cannot place a view");
    p.poses.push_back(pose);
  }
  const Problem problem(true, object_points, image_points, freeIndices(fixed));
  return solve(problem, std::move(p), corners, criteria, false, camera_matrix, distortion, rvecs,
               tvecs);
}

}  // namespace camera
}  // namespace autocal
