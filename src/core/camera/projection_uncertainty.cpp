#include "autocal/camera/projection_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace autocal {
namespace camera {

namespace {

/// The indices of the free parameters among [fx fy cx cy, distortion...] (projectPoints'
/// Jacobian has them from column 6 on, after rvec and tvec).
std::vector<int> freeParameters(const std::vector<bool>& fitted) {
  std::vector<int> out;
  for (size_t i = 0; i < fitted.size(); ++i)
    if (fitted[i]) out.push_back(static_cast<int>(i));
  return out;
}

/// The columns `free` (offset by 6) of projectPoints' Jacobian, as a 2n x free.size() matrix.
cv::Mat intrinsicColumns(const cv::Mat& jacobian, const std::vector<int>& free) {
  cv::Mat a(jacobian.rows, static_cast<int>(free.size()), CV_64F);
  for (size_t c = 0; c < free.size(); ++c)
    jacobian.col(6 + free[c]).copyTo(a.col(static_cast<int>(c)));
  return a;
}

bool supported(const CameraIntrinsics& in) {
  return in.distortion_model == DistortionModel::kPlumbBob ||
         in.distortion_model == DistortionModel::kRationalPolynomial;
}

}  // namespace

cv::Matx22d projectionCovariance(const CameraIntrinsics& in, const std::vector<bool>& fitted,
                                 const cv::Mat& cov, const cv::Point2d& pixel) {
  const cv::Mat k(in.cameraMatrix()), d(in.distortion_coefficients);
  std::vector<cv::Point2d> raw{pixel}, normalised;
  cv::undistortPoints(raw, normalised, k, d);
  const std::vector<cv::Point3d> ray{{normalised[0].x, normalised[0].y, 1.0}};
  std::vector<cv::Point2d> projected;
  cv::Mat jacobian;
  cv::projectPoints(ray, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, d, projected, jacobian);
  const cv::Mat g = intrinsicColumns(jacobian, freeParameters(fitted));
  const cv::Mat c = g * cov * g.t();
  return cv::Matx22d(c.at<double>(0, 0), c.at<double>(0, 1), c.at<double>(1, 0),
                     c.at<double>(1, 1));
}

std::vector<double> projectionDifferences(const CameraIntrinsics& a, const CameraIntrinsics& b,
                                          int cols, int rows) {
  std::vector<cv::Point2d> pixels, normalised, projected;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      pixels.emplace_back((c + 0.5) * a.width / cols, (r + 0.5) * a.height / rows);
  cv::undistortPoints(pixels, normalised, cv::Mat(a.cameraMatrix()),
                      cv::Mat(a.distortion_coefficients));
  std::vector<cv::Point3d> rays;
  for (const cv::Point2d& n : normalised) rays.emplace_back(n.x, n.y, 1.0);
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(b.cameraMatrix()),
                    cv::Mat(b.distortion_coefficients), projected);
  std::vector<double> out;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double d = std::hypot(projected[i].x - pixels[i].x, projected[i].y - pixels[i].y);
    out.push_back(std::isfinite(d) ? d : std::nan(""));
  }
  return out;
}

ProjectionUncertainty projectionUncertainty(
    const std::vector<std::vector<cv::Point3f>>& object_points,
    const std::vector<std::vector<cv::Point2f>>& image_points, const std::vector<cv::Mat>& rvecs,
    const std::vector<cv::Mat>& tvecs, const CameraIntrinsics& in, const std::vector<bool>& fitted,
    int cols, int rows) {
  ProjectionUncertainty out;
  const std::vector<int> free = freeParameters(fitted);
  const int p = static_cast<int>(free.size());
  if (!supported(in) || p == 0 || cols <= 0 || rows <= 0 || object_points.empty() ||
      object_points.size() != image_points.size() || rvecs.size() != object_points.size() ||
      tvecs.size() != object_points.size())
    return out;
  const cv::Mat k(in.cameraMatrix()), d(in.distortion_coefficients);
  // J^T J over the intrinsics and each view's pose, with the poses eliminated as they are found
  // (a Schur complement): U - sum_v W_v V_v^-1 W_v^T is the intrinsics' information.
  cv::Mat information = cv::Mat::zeros(p, p, CV_64F);
  double squared = 0;
  int residuals = 0;
  for (size_t v = 0; v < object_points.size(); ++v) {
    std::vector<cv::Point2d> projected;
    cv::Mat jacobian;
    std::vector<cv::Point3d> obj(object_points[v].begin(), object_points[v].end());
    cv::projectPoints(obj, rvecs[v], tvecs[v], k, d, projected, jacobian);
    for (size_t i = 0; i < projected.size(); ++i) {
      const double dx = projected[i].x - image_points[v][i].x;
      const double dy = projected[i].y - image_points[v][i].y;
      squared += dx * dx + dy * dy;
    }
    residuals += 2 * static_cast<int>(projected.size());
    const cv::Mat a = intrinsicColumns(jacobian, free);
    const cv::Mat b = jacobian.colRange(0, 6);
    const cv::Mat w = a.t() * b;
    const cv::Mat pose = b.t() * b;
    information += a.t() * a - w * pose.inv(cv::DECOMP_SVD) * w.t();
  }
  const int dof = residuals - p - 6 * static_cast<int>(object_points.size());
  if (dof <= 0) return out;
  const double variance = squared / dof;
  const cv::Mat cov = information.inv(cv::DECOMP_SVD) * variance;
  out.corner_noise_px = std::sqrt(variance);
  out.cols = cols;
  out.rows = rows;
  double sum = 0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const cv::Point2d pixel((c + 0.5) * in.width / cols, (r + 0.5) * in.height / rows);
      const cv::Matx22d s = projectionCovariance(in, fitted, cov, pixel);
      // The larger eigenvalue of the symmetric 2x2 covariance.
      const double mean = 0.5 * (s(0, 0) + s(1, 1));
      const double half = std::hypot(0.5 * (s(0, 0) - s(1, 1)), s(0, 1));
      const double sigma = std::sqrt(std::max(0.0, mean + half));
      out.sigma_px.push_back(sigma);
      sum += sigma * sigma;
      out.worst_px = std::max(out.worst_px, sigma);
      if (2 * r >= rows) out.lower_half_worst_px = std::max(out.lower_half_worst_px, sigma);
    }
  }
  out.rms_px = std::sqrt(sum / static_cast<double>(out.sigma_px.size()));
  out.valid = true;
  return out;
}

}  // namespace camera
}  // namespace autocal
