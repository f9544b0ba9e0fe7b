#include "autocal/camera/projection_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace camera {

namespace {

/// The indices of the free parameters among [fx fy cx cy, distortion...].
std::vector<int> freeParameters(const std::vector<bool>& fitted) {
  std::vector<int> out;
  for (size_t i = 0; i < fitted.size(); ++i)
    if (fitted[i]) out.push_back(static_cast<int>(i));
  return out;
}

/// The columns `free` of an intrinsics Jacobian, as a 2n x free.size() matrix.
cv::Mat intrinsicColumns(const cv::Mat& jacobian, const std::vector<int>& free) {
  cv::Mat a(jacobian.rows, static_cast<int>(free.size()), CV_64F);
  for (size_t c = 0; c < free.size(); ++c) jacobian.col(free[c]).copyTo(a.col(static_cast<int>(c)));
  return a;
}

bool fisheye(const CameraIntrinsics& in) {
  return in.distortion_model == DistortionModel::kEquidistant;
}

/// Points projected with `in` from the pose, and the Jacobians of the projection with respect to
/// the pose (2n x 6: rvec, tvec) and to the intrinsics (2n x (4 + terms): fx fy cx cy, terms).
struct Projection {
  std::vector<cv::Point2d> points;
  cv::Mat pose, intrinsics;
};
Projection projectWithJacobians(const std::vector<cv::Point3d>& points, const cv::Mat& rvec,
                                const cv::Mat& tvec, const CameraIntrinsics& in) {
  const cv::Mat k(in.cameraMatrix()), d(in.distortion_coefficients);
  Projection out;
  cv::Mat jacobian;
  if (fisheye(in)) {
    // Columns: f (2), c (2), k1..k4, rvec (3), tvec (3), skew.
    cv::fisheye::projectPoints(points, out.points, rvec, tvec, k, d, 0, jacobian);
    cv::hconcat(jacobian.colRange(8, 11), jacobian.colRange(11, 14), out.pose);
    out.intrinsics = jacobian.colRange(0, 8).clone();
  } else {
    // Columns: rvec (3), tvec (3), f (2), c (2), the terms.
    cv::projectPoints(points, rvec, tvec, k, d, out.points, jacobian);
    out.pose = jacobian.colRange(0, 6).clone();
    out.intrinsics = jacobian.colRange(6, jacobian.cols).clone();
  }
  return out;
}

/// The camera frame's own pose: no rotation, no translation.
cv::Mat zero3() { return cv::Mat::zeros(3, 1, CV_64F); }

/// How far the ray (x, y, 1) projects from `pixel` under `in` [px], and the Jacobian of its
/// projection with respect to x and y (with no rotation or translation, the derivative by the
/// translation's x and y is that by the point's).
double rayResidual(const CameraIntrinsics& in, const cv::Point2d& xy, const cv::Point2d& pixel,
                   cv::Point2d* residual, cv::Matx22d* jacobian) {
  const Projection p = projectWithJacobians({cv::Point3d(xy.x, xy.y, 1.0)}, zero3(), zero3(), in);
  *residual = pixel - p.points[0];
  if (jacobian) {
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) (*jacobian)(r, c) = p.pose.at<double>(r, 3 + c);
  }
  return std::hypot(residual->x, residual->y);
}

}  // namespace

std::vector<cv::Point3d> pixelRays(const CameraIntrinsics& in,
                                   const std::vector<cv::Point2d>& pixels) {
  std::vector<cv::Point2d> normalised;
  if (fisheye(in)) {
    cv::fisheye::undistortPoints(pixels, normalised, cv::Mat(in.cameraMatrix()),
                                 cv::Mat(in.distortion_coefficients));
  } else {
    cv::undistortPoints(pixels, normalised, cv::Mat(in.cameraMatrix()),
                        cv::Mat(in.distortion_coefficients));
  }
  std::vector<cv::Point3d> out;
  for (size_t i = 0; i < pixels.size(); ++i) {
    // Start from OpenCV's answer or the pinhole one, whichever lands nearer.
    const cv::Point2d pinhole((pixels[i].x - in.cx) / in.fx, (pixels[i].y - in.cy) / in.fy);
    cv::Point2d xy = normalised[i], residual, pinhole_residual;
    cv::Matx22d jacobian;
    double error = rayResidual(in, xy, pixels[i], &residual, &jacobian);
    if (!(error < 1e300) ||
        rayResidual(in, pinhole, pixels[i], &pinhole_residual, nullptr) < error) {
      xy = pinhole;
      error = rayResidual(in, xy, pixels[i], &residual, &jacobian);
    }
    for (int it = 0; it < 50 && error > 1e-9; ++it) {
      const cv::Vec2d step = jacobian.solve(cv::Vec2d(residual.x, residual.y), cv::DECOMP_SVD);
      // A step that does not reduce the error is halved (a Newton step may overshoot where the
      // distortion bends hard).
      double scale = 1.0;
      cv::Point2d next, next_residual;
      cv::Matx22d next_jacobian;
      double next_error = error;
      for (int h = 0; h < 20; ++h, scale *= 0.5) {
        next = xy + scale * cv::Point2d(step[0], step[1]);
        next_error = rayResidual(in, next, pixels[i], &next_residual, &next_jacobian);
        if (next_error < error) break;
      }
      if (!(next_error < error)) break;
      xy = next, residual = next_residual, jacobian = next_jacobian, error = next_error;
    }
    out.push_back(error <= 1e-6 ? cv::Point3d(xy.x, xy.y, 1.0)
                                : cv::Point3d(std::nan(""), std::nan(""), 1.0));
  }
  return out;
}

namespace {

/// The 2 x free Jacobian of projecting the ray of `pixel` (fixed in the camera frame) with
/// respect to the free intrinsics.
cv::Mat projectionJacobian(const CameraIntrinsics& in, const std::vector<bool>& fitted,
                           const cv::Point2d& pixel) {
  const Projection p = projectWithJacobians(pixelRays(in, {pixel}), zero3(), zero3(), in);
  return intrinsicColumns(p.intrinsics, freeParameters(fitted));
}

cv::Matx22d covarianceThrough(const cv::Mat& g, const cv::Mat& cov) {
  const cv::Mat c = g * cov * g.t();
  return cv::Matx22d(c.at<double>(0, 0), c.at<double>(0, 1), c.at<double>(1, 0),
                     c.at<double>(1, 1));
}

/// The larger eigenvalue of a symmetric 2x2 covariance.
double worstVariance(const cv::Matx22d& s) {
  return 0.5 * (s(0, 0) + s(1, 1)) + std::hypot(0.5 * (s(0, 0) - s(1, 1)), s(0, 1));
}

}  // namespace

cv::Matx22d projectionCovariance(const CameraIntrinsics& in, const std::vector<bool>& fitted,
                                 const cv::Mat& cov, const cv::Point2d& pixel) {
  return covarianceThrough(projectionJacobian(in, fitted, pixel), cov);
}

std::vector<cv::Point2d> ImageGrid::centres(int width, int height) const {
  std::vector<cv::Point2d> out;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out.push_back(centre(c, r, width, height));
  return out;
}

std::vector<double> projectionDifferences(const CameraIntrinsics& a, const CameraIntrinsics& b,
                                          const ImageGrid& grid) {
  const std::vector<cv::Point2d> pixels = grid.centres(a.width, a.height);
  const std::vector<cv::Point2d> projected =
      projectWithJacobians(pixelRays(a, pixels), zero3(), zero3(), b).points;
  std::vector<double> out;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double d = std::hypot(projected[i].x - pixels[i].x, projected[i].y - pixels[i].y);
    out.push_back(std::isfinite(d) ? d : std::nan(""));
  }
  return out;
}

namespace {

/// Whether the inputs describe one fit: as many views of points as of corners and of poses.
bool consistent(const std::vector<std::vector<cv::Point3f>>& object_points,
                const std::vector<std::vector<cv::Point2f>>& image_points,
                const std::vector<cv::Mat>& rvecs, const std::vector<cv::Mat>& tvecs) {
  if (object_points.empty() || object_points.size() != image_points.size() ||
      rvecs.size() != object_points.size() || tvecs.size() != object_points.size())
    return false;
  for (size_t v = 0; v < object_points.size(); ++v)
    if (object_points[v].size() != image_points[v].size()) return false;
  return true;
}

/// The intrinsics' information at the fit: J^T J over the intrinsics and each view's pose, the
/// poses eliminated as they are found (a Schur complement: U - sum_v W_v V_v^-1 W_v^T), with the
/// sum of the squared residuals and their count; and the sum over views of each view's score
/// outer product, s_v s_v^T with s_v = A_v^T r_v (A_v: the view's intrinsics Jacobian, r_v its
/// residuals; at the optimum r_v is orthogonal to the view's pose Jacobian, so the pose needs no
/// elimination here).
struct Information {
  cv::Mat intrinsics;
  cv::Mat view_scores;
  double squared = 0;
  int residuals = 0;
};
Information information(const std::vector<std::vector<cv::Point3f>>& object_points,
                        const std::vector<std::vector<cv::Point2f>>& image_points,
                        const std::vector<cv::Mat>& rvecs, const std::vector<cv::Mat>& tvecs,
                        const CameraIntrinsics& in, const std::vector<int>& free) {
  const int p = static_cast<int>(free.size());
  Information n;
  n.intrinsics = cv::Mat::zeros(p, p, CV_64F);
  n.view_scores = cv::Mat::zeros(p, p, CV_64F);
  for (size_t v = 0; v < object_points.size(); ++v) {
    const std::vector<cv::Point3d> obj(object_points[v].begin(), object_points[v].end());
    const Projection proj = projectWithJacobians(obj, rvecs[v], tvecs[v], in);
    cv::Mat r(2 * static_cast<int>(proj.points.size()), 1, CV_64F);
    for (size_t i = 0; i < proj.points.size(); ++i) {
      const double dx = proj.points[i].x - image_points[v][i].x;
      const double dy = proj.points[i].y - image_points[v][i].y;
      r.at<double>(2 * static_cast<int>(i)) = dx;
      r.at<double>(2 * static_cast<int>(i) + 1) = dy;
      n.squared += dx * dx + dy * dy;
    }
    n.residuals += 2 * static_cast<int>(proj.points.size());
    const cv::Mat a = intrinsicColumns(proj.intrinsics, free);
    const cv::Mat score = a.t() * r;
    n.view_scores += score * score.t();
    const cv::Mat& b = proj.pose;
    const cv::Mat w = a.t() * b;
    n.intrinsics += a.t() * a - w * (b.t() * b).inv(cv::DECOMP_SVD) * w.t();
  }
  return n;
}

}  // namespace

std::vector<double> IntrinsicsCovariance::std_devs(size_t parameters) const {
  std::vector<double> out(parameters, 0.0);
  for (size_t k = 0; k < free.size(); ++k)
    if (free[k] < static_cast<int>(parameters))
      out[static_cast<size_t>(free[k])] =
          std::sqrt(std::max(0.0, cov.at<double>(static_cast<int>(k), static_cast<int>(k))));
  return out;
}

IntrinsicsCovariance intrinsicsCovariance(
    const std::vector<std::vector<cv::Point3f>>& object_points,
    const std::vector<std::vector<cv::Point2f>>& image_points, const std::vector<cv::Mat>& rvecs,
    const std::vector<cv::Mat>& tvecs, const CameraIntrinsics& in,
    const std::vector<bool>& fitted) {
  IntrinsicsCovariance out;
  out.free = freeParameters(fitted);
  const int p = static_cast<int>(out.free.size());
  if (p == 0 || !consistent(object_points, image_points, rvecs, tvecs)) return out;
  const Information n = information(object_points, image_points, rvecs, tvecs, in, out.free);
  const int dof = n.residuals - p - 6 * static_cast<int>(object_points.size());
  if (dof <= 0) return out;
  const double variance = n.squared / dof;
  const cv::Mat inverse = n.intrinsics.inv(cv::DECOMP_SVD);
  out.cov = inverse * variance;
  out.corner_noise_px = std::sqrt(variance);
  const int views = static_cast<int>(object_points.size());
  if (views >= 2) {
    // The small-sample factor of the clustered sandwich (CR1): G / (G - 1) * (N - 1) / (N - K).
    const double factor = views / (views - 1.0) * (n.residuals - 1.0) / dof;
    out.view_clustered_cov = inverse * n.view_scores * inverse * factor;
  }
  out.valid = true;
  return out;
}

ProjectionUncertainty projectionUncertainty(
    const std::vector<std::vector<cv::Point3f>>& object_points,
    const std::vector<std::vector<cv::Point2f>>& image_points, const std::vector<cv::Mat>& rvecs,
    const std::vector<cv::Mat>& tvecs, const CameraIntrinsics& in, const std::vector<bool>& fitted,
    const ImageGrid& grid) {
  if (grid.cells() == 0) return {};
  return projectionUncertainty(
      intrinsicsCovariance(object_points, image_points, rvecs, tvecs, in, fitted), in, fitted,
      grid);
}

ProjectionUncertainty projectionUncertainty(const IntrinsicsCovariance& covariance,
                                            const CameraIntrinsics& in,
                                            const std::vector<bool>& fitted,
                                            const ImageGrid& grid) {
  ProjectionUncertainty out;
  if (grid.cells() == 0 || !covariance.valid) return out;
  const cv::Mat& cov = covariance.cov;
  out.corner_noise_px = covariance.corner_noise_px;
  out.grid = grid;
  const int rows = grid.rows, cols = grid.cols;
  double sum = 0;
  const cv::Mat& clustered = covariance.view_clustered_cov;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const cv::Mat g = projectionJacobian(in, fitted, grid.centre(c, r, in.width, in.height));
      // The larger of the two estimates: the corners' noise taken as independent, and the views'
      // own scatter.
      const double independent = worstVariance(covarianceThrough(g, cov));
      double variance = independent;
      if (!clustered.empty() && std::isfinite(variance))
        variance = std::max(variance, worstVariance(covarianceThrough(g, clustered)));
      if (!std::isfinite(variance)) {  // no ray: beyond where the model maps
        out.sigma_px.push_back(std::nan(""));
        out.independent_sigma_px.push_back(std::nan(""));
        ++out.unmapped;
        continue;
      }
      const double sigma = std::sqrt(std::max(0.0, variance));
      out.independent_sigma_px.push_back(std::sqrt(std::max(0.0, independent)));
      out.sigma_px.push_back(sigma);
      sum += sigma * sigma;
      out.worst_px = std::max(out.worst_px, sigma);
      if (2 * r >= rows) out.lower_half_worst_px = std::max(out.lower_half_worst_px, sigma);
    }
  }
  const size_t mapped = out.sigma_px.size() - static_cast<size_t>(out.unmapped);
  if (mapped == 0) return out;
  out.rms_px = std::sqrt(sum / static_cast<double>(mapped));
  out.valid = true;
  return out;
}

}  // namespace camera
}  // namespace autocal
