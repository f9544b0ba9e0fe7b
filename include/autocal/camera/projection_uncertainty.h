// How sure a calibration is of where it projects, over the whole image: the fit's covariance,
// from the observed corner noise, carried to each pixel of a grid. Each board corner's residual is
// taken as independent noise of one standard deviation sigma (estimated from the residuals, with
// the fit's degrees of freedom); the covariance of the intrinsics is the marginal block of
// sigma^2 (J^T J)^-1 over the intrinsics and every view's pose (J: the residuals' Jacobian at the
// optimum); a grid pixel's ray, fixed in the camera frame, is projected with the intrinsics and
// its 2x2 covariance is G Sigma G^T (G: the projection's Jacobian with respect to the intrinsics).
// This is the propagation mrcal makes (its documentation, "Projection uncertainty"), without its
// compensation of the reference frame's motion between calibrations: it is the uncertainty of the
// projection difference as the simulator measures it (a ray fixed in the camera frame).
// A board's corners are not independent, though: the detector's error follows the edges' phase
// on the pixel grid and is alike along a row of corners, and boards seen at a slant (the floor's)
// err more than the others. The simulator's corners err by 0.07-0.09 px RMS rendered without any
// pixel noise, and a wide lens's written model was off by 3 sigma over 30 % of the image. So each
// cell's sigma is the larger of that and the same propagation with the views' own scatter: the
// covariance clustered by view (a sandwich, H^-1 (sum_v s_v s_v^T) H^-1, s_v the view's score on
// the intrinsics; Liang and Zeger's cluster-robust estimator, with its small-sample factor).
// ROS-free.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "autocal/camera_intrinsics.h"

namespace autocal {
namespace camera {

/// The grid over the image on which every whole-image figure is taken (the uncertainty, the
/// halves' cross-validation, the difference between models, where more views are wanted): cols x
/// rows cells, each judged at its centre.
struct ImageGrid {
  int cols = 16, rows = 12;
  size_t cells() const { return cols > 0 && rows > 0 ? static_cast<size_t>(cols * rows) : 0; }
  /// The centre of cell (c, r) in a width x height image [px].
  cv::Point2d centre(int c, int r, int width, int height) const {
    return {(c + 0.5) * width / cols, (r + 0.5) * height / rows};
  }
  /// Every cell's centre, row-major.
  std::vector<cv::Point2d> centres(int width, int height) const;
};

struct ProjectionUncertainty {
  bool valid = false;  ///< false: the fit gives none (no free parameter, too few corners)
  ImageGrid grid;      ///< the cells of sigma_px
  /// Per grid cell, row-major: the standard deviation of the projection in its worst direction
  /// [px] (the square root of the covariance's larger eigenvalue); NaN where the model maps no ray
  /// to the cell's centre (not counted in the figures below).
  std::vector<double> sigma_px;
  /// The same with the corners' noise taken as independent only (no view's scatter): what the
  /// halves' cross-validation measures a difference against, since a lens the model does not fit
  /// scatters the views too.
  std::vector<double> independent_sigma_px;
  int unmapped = 0;
  double corner_noise_px = 0;      ///< sigma estimated from the residuals [px]
  double worst_px = 0;             ///< the largest sigma_px
  double rms_px = 0;               ///< root mean square of sigma_px over the grid
  double lower_half_worst_px = 0;  ///< the largest sigma_px in the lower half (the floor)
};

/// The covariance of a fit's free intrinsics (see the file's comment), with the corner noise it
/// was scaled by.
struct IntrinsicsCovariance {
  bool valid = false;  ///< false: no free parameter, too few residuals, or mismatched inputs
  std::vector<int> free;  ///< the indices among [fx fy cx cy, terms] of cov's rows
  cv::Mat cov;            ///< free.size() square [px^2 and the terms' units]
  /// The same from the views' own scatter (a sandwich clustered by view): what the corners'
  /// errors give when they are correlated within a view or larger in some views than in others,
  /// as a chessboard's corners are (see the file's comment); empty under two views.
  cv::Mat view_clustered_cov;
  double corner_noise_px = 0;
  /// The standard deviation of every parameter of [fx fy cx cy, terms]: 0 for a fixed one.
  std::vector<double> std_devs(size_t parameters) const;
};

/// The covariance of `intrinsics` fitted to `object_points` seen at `image_points` from the
/// poses `rvecs`, `tvecs`, over the parameters `fitted` says were free.
IntrinsicsCovariance intrinsicsCovariance(
    const std::vector<std::vector<cv::Point3f>>& object_points,
    const std::vector<std::vector<cv::Point2f>>& image_points, const std::vector<cv::Mat>& rvecs,
    const std::vector<cv::Mat>& tvecs, const CameraIntrinsics& intrinsics,
    const std::vector<bool>& fitted);

/// The projection uncertainty of `intrinsics`, fitted to `object_points` seen at
/// `image_points` from the poses `rvecs`, `tvecs` (the fit's, one per view). `fitted[i]` says
/// whether parameter i of [fx fy cx cy, the distortion terms in their order] was free in the fit
/// (a fixed one has no uncertainty). Every model's projection is supported.
ProjectionUncertainty projectionUncertainty(
    const std::vector<std::vector<cv::Point3f>>& object_points,
    const std::vector<std::vector<cv::Point2f>>& image_points, const std::vector<cv::Mat>& rvecs,
    const std::vector<cv::Mat>& tvecs, const CameraIntrinsics& intrinsics,
    const std::vector<bool>& fitted, const ImageGrid& grid = {});

/// The same from the intrinsics' covariance, where the fit already computed it (an equidistant
/// fit, whose standard deviations come from it).
ProjectionUncertainty projectionUncertainty(const IntrinsicsCovariance& covariance,
                                            const CameraIntrinsics& intrinsics,
                                            const std::vector<bool>& fitted,
                                            const ImageGrid& grid = {});

/// Two calibrations from disjoint halves of the views (every other view), with the same model and
/// terms, compared over the grid: each pixel's ray under the first projected with the second. A
/// difference well beyond what their uncertainties allow (ratio above about 2) says the model does
/// not fit the lens, not the noise (mrcal's cross-validation).
struct HalvesCrossValidation {
  bool valid = false;  ///< false: too few views (8 at least), or no uncertainty for the model
  int views_each = 0;
  double rms_px = 0;    ///< the difference's RMS over the grid
  double worst_px = 0;  ///< its largest
  /// The RMS over the grid of sqrt(sigma_a^2 + sigma_b^2), each half's sigma with the corners'
  /// noise taken as independent (ProjectionUncertainty::independent_sigma_px): what the
  /// difference should be if the model fits.
  double expected_rms_px = 0;
  /// The RMS over the grid of each cell's difference over sqrt(sigma_a^2 + sigma_b^2): 1 to 1.4
  /// when the model fits (the difference is noise), well above 2 when it does not. Per cell, so
  /// that the well-determined middle of the image counts as much as its uncertain corners.
  double ratio = 0;
};

/// The projection difference between two intrinsics over the cells of `grid`: each cell
/// centre's ray under `a` projected with `b` [px], row-major (NaN where `a` has no ray).
std::vector<double> projectionDifferences(const CameraIntrinsics& a, const CameraIntrinsics& b,
                                          const ImageGrid& grid);

/// Each pixel's ray under `in`, as a point at depth 1 in the camera frame: OpenCV's undistortion,
/// then Newton's method on the projection itself. OpenCV's fixed-point undistortion alone does
/// not converge over much of the image of a strongly distorted lens (plumb_bob k1 = -0.4: 152 of
/// a 16 x 12 grid's cells came back off, some by hundreds of pixels). NaN where no ray projects
/// within 1e-6 px of the pixel (beyond where the model maps).
std::vector<cv::Point3d> pixelRays(const CameraIntrinsics& in,
                                   const std::vector<cv::Point2d>& pixels);

/// The 2x2 covariance of projecting the ray of `pixel` (fixed in the camera frame) with
/// intrinsics whose covariance is `cov` over the free parameters `fitted`.
cv::Matx22d projectionCovariance(const CameraIntrinsics& intrinsics,
                                 const std::vector<bool>& fitted, const cv::Mat& cov,
                                 const cv::Point2d& pixel);

}  // namespace camera
}  // namespace autocal
