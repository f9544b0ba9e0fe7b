// The joint fit of a camera's intrinsics and every view's pose to the views' corners (Zhang's
// method, paper 000 §1): cv::calibrateCamera's least squares for a pinhole camera (plumb_bob or
// rational_polynomial), and the same for the equidistant (fisheye) model, solved by
// Levenberg-Marquardt with the views' poses eliminated in each step. OpenCV's solver decomposes
// the whole normal matrix (intrinsics and 6 pose parameters per view) in every iteration, and its
// fisheye fit inverts it and places every view again; their cost grows with the cube of the
// number of views. Here each step solves the intrinsics' block of it (a Schur complement, as
// bundle adjustment does) and then each pose alone: the same minimum, in a small part of the
// time.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace autocal {
namespace camera {

struct JointFit {
  double rms_px = 0;  ///< over the corners (as cv::calibrateCamera returns it)
  /// Standard deviations of [fx fy cx cy, the distortion terms] as cv::calibrateCamera (OpenCV
  /// 4.6) reports them; 0 for a fixed one.
  std::vector<double> std_devs;
  int iterations = 0;
};

/// Fits `camera_matrix` (3x3) and `distortion` (5 terms, or 8 with cv::CALIB_RATIONAL_MODEL) and
/// one pose per view, as cv::calibrateCamera does with `flags` (CALIB_USE_INTRINSIC_GUESS,
/// CALIB_ZERO_TANGENT_DIST, CALIB_FIX_K1..K6, CALIB_RATIONAL_MODEL; other flags are refused with
/// cv::Exception) and `criteria`. Without CALIB_USE_INTRINSIC_GUESS the camera matrix starts from
/// the views' homographies and the distortion at 0, as OpenCV starts. Throws cv::Exception where
/// OpenCV would (too few points, a start that places no view).
JointFit fitPinhole(const std::vector<std::vector<cv::Point3f>>& object_points,
                    const std::vector<std::vector<cv::Point2f>>& image_points,
                    const cv::Size& image_size, cv::Mat& camera_matrix, cv::Mat& distortion,
                    std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs, int flags,
                    const cv::TermCriteria& criteria);

/// The same for the equidistant model (cv::fisheye's): `camera_matrix` and `distortion` (k1..k4)
/// as cv::fisheye::calibrate fits them with `flags` (cv::fisheye::CALIB_USE_INTRINSIC_GUESS,
/// CALIB_RECOMPUTE_EXTRINSIC, CALIB_FIX_SKEW, CALIB_FIX_K1..K4; skew is never fitted). Without
/// the guess it starts as OpenCV does: the focal length the image's larger side over pi, the
/// principal point the image's centre. Each view is placed with the starting model; a corner it
/// maps no ray to throws cv::Exception (the caller starts again from elsewhere). std_devs are
/// left empty (the caller's covariance gives them).
JointFit fitEquidistant(const std::vector<std::vector<cv::Point3d>>& object_points,
                        const std::vector<std::vector<cv::Point2d>>& image_points,
                        const cv::Size& image_size, cv::Mat& camera_matrix, cv::Mat& distortion,
                        std::vector<cv::Mat>& rvecs, std::vector<cv::Mat>& tvecs, int flags,
                        const cv::TermCriteria& criteria);

}  // namespace camera
}  // namespace autocal
