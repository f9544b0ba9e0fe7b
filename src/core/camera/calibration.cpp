#include "autocal/camera/calibration.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <optional>

#include "autocal/camera/joint_fit.h"
#include "autocal/camera/view_selection.h"
#include "autocal/errors.h"
#include "autocal/parallel.h"

namespace autocal {
namespace camera {

namespace {

using Points2 = std::vector<cv::Point2f>;
using Points3 = std::vector<cv::Point3f>;

bool isFisheye(DistortionModel m) { return m == DistortionModel::kEquidistant; }

// A set of distortion terms to fit, simplest first (the others are held at 0).
struct TermSet {
  std::string name;
  int flags;
  std::vector<int> added;  // distortion indices this set fits beyond the previous one
};

std::vector<TermSet> termSets(DistortionModel model) {
  switch (model) {
    case DistortionModel::kPlumbBob:
      return {
          {"k1 k2 (p1 p2 k3 fixed at 0)", cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3, {0, 1}},
          {"k1 k2 p1 p2 (k3 fixed at 0)", cv::CALIB_FIX_K3, {2, 3}},
          {"k1 k2 p1 p2 k3", 0, {4}}};
    case DistortionModel::kRationalPolynomial: {
      const int r = cv::CALIB_RATIONAL_MODEL;
      return {{"k1 k2 p1 p2 (k3..k6 fixed at 0)",
               r | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 | cv::CALIB_FIX_K5 | cv::CALIB_FIX_K6,
               {0, 1, 2, 3}},
              {"k1 k2 p1 p2 k3 (k4..k6 fixed at 0)",
               r | cv::CALIB_FIX_K4 | cv::CALIB_FIX_K5 | cv::CALIB_FIX_K6,
               {4}},
              {"k1 k2 p1 p2 k3 k4 k5 k6", r, {5, 6, 7}}};
    }
    case DistortionModel::kEquidistant: {
      const int f = cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW;
      return {{"k1 k2 (k3 k4 fixed at 0)",
               f | cv::fisheye::CALIB_FIX_K3 | cv::fisheye::CALIB_FIX_K4,
               {0, 1}},
              {"k1 k2 k3 (k4 fixed at 0)", f | cv::fisheye::CALIB_FIX_K4, {2}},
              {"k1 k2 k3 k4", f, {3}}};
    }
  }
  return {};
}

struct Fit {
  CameraIntrinsics intrinsics;
  double rms_px = 0;
  std::vector<double> std_devs;
  std::vector<cv::Mat> rvecs, tvecs;
  /// The covariance of the free intrinsics where the fit computed it (equidistant: OpenCV reports
  /// no standard deviations for it); not valid otherwise.
  IntrinsicsCovariance covariance;
};

/// The projection uncertainty of fit `f` of `obj` seen at `img`, over `grid`.
ProjectionUncertainty uncertaintyOf(const Fit& f, const std::vector<Points3>& obj,
                                    const std::vector<Points2>& img,
                                    const std::vector<bool>& fitted, const ImageGrid& grid = {}) {
  std::vector<int> free;
  for (size_t i = 0; i < fitted.size(); ++i)
    if (fitted[i]) free.push_back(static_cast<int>(i));
  if (f.covariance.valid && f.covariance.free == free)
    return projectionUncertainty(f.covariance, f.intrinsics, fitted, grid);
  return projectionUncertainty(obj, img, f.rvecs, f.tvecs, f.intrinsics, fitted, grid);
}

size_t distortionCount(DistortionModel m) {
  return m == DistortionModel::kPlumbBob ? 5 : m == DistortionModel::kRationalPolynomial ? 8 : 4;
}

/// A camera matrix from the views' homographies (cv::initCameraMatrix2D), empty when it gives
/// none.
cv::Mat pinholeStart(const std::vector<std::vector<cv::Point3d>>& obj,
                     const std::vector<std::vector<cv::Point2d>>& img, const cv::Size& size) {
  std::vector<std::vector<cv::Point3f>> o;
  std::vector<std::vector<cv::Point2f>> i;
  for (const auto& v : obj) o.emplace_back(v.begin(), v.end());
  for (const auto& v : img) i.emplace_back(v.begin(), v.end());
  try {
    cv::Mat k = cv::initCameraMatrix2D(o, i, size);
    k.convertTo(k, CV_64F);
    if (!(k.at<double>(0, 0) > 0 && k.at<double>(1, 1) > 0)) return {};
    return k;
  } catch (const cv::Exception&) {
    return {};
  }
}

/// The equidistant fit (fitEquidistant, cv::fisheye::calibrate's least squares), started from k,
/// d when `flags` asks for the guess. The fit first places every view with the starting model; a
/// start far from the lens can leave a view's corners unplaceable and the fit throws, though the
/// views fit well: a warm start whose k3, k4 ran off on views that do not pin them, a focal length
/// twice too long, or OpenCV's own start, whose focal length (the image's larger side over π)
/// maps no ray in front of the camera beyond f·π/2 from the centre (320 px for 640 x 480): a
/// robot's view with a corner 322 px out made OpenCV's fit throw ("norm_u1 > 0"). Then it is
/// started again: from the same camera matrix without distortion, from OpenCV's own start, and
/// from a pinhole camera matrix fitted to the views' homographies; the error of the first try is
/// rethrown when every start fails.
double fisheyeCalibrate(const std::vector<std::vector<cv::Point3d>>& obj,
                        const std::vector<std::vector<cv::Point2d>>& img, const cv::Size& size,
                        cv::Mat& k, cv::Mat& d, std::vector<cv::Mat>& rvecs,
                        std::vector<cv::Mat>& tvecs, int flags, const cv::TermCriteria& criteria) {
  const cv::Mat k_start = k.clone(), d_start = d.clone();
  const bool guessed = (flags & cv::fisheye::CALIB_USE_INTRINSIC_GUESS) != 0;
  try {
    return fitEquidistant(obj, img, size, k, d, rvecs, tvecs, flags, criteria).rms_px;
  } catch (const cv::Exception& first) {
    std::vector<int> retries;
    if (guessed && cv::countNonZero(d_start) > 0) retries.push_back(flags);
    if (guessed) retries.push_back(flags & ~cv::fisheye::CALIB_USE_INTRINSIC_GUESS);
    // A pinhole start from the views' homographies (OpenCV's own start is a focal length from
    // the image's size alone).
    const cv::Mat pinhole = pinholeStart(obj, img, size);
    if (!pinhole.empty()) retries.push_back(flags | cv::fisheye::CALIB_USE_INTRINSIC_GUESS);
    for (size_t i = 0; i < retries.size(); ++i) {
      const bool last = i + 1 == retries.size();
      k = (!pinhole.empty() && last ? pinhole : k_start).clone();
      d = cv::Mat::zeros(4, 1, CV_64F);
      try {
        return fitEquidistant(obj, img, size, k, d, rvecs, tvecs, retries[i], criteria).rms_px;
      } catch (const cv::Exception&) {
      }
    }
    throw first;
  }
}

Fit fit(const std::vector<Points3>& obj, const std::vector<Points2>& img, const cv::Size& size,
        DistortionModel model, int flags, const CameraIntrinsics* guess = nullptr,
        bool opencv_default_criteria = false) {
  Fit f;
  f.intrinsics.distortion_model = model;
  f.intrinsics.setImageSize(size);
  cv::Mat k, d;
  if (guess) {
    // Warm start (folds of a cross-validation start from the fit on all views): same optimum,
    // far fewer iterations.
    k = cv::Mat(guess->cameraMatrix()).clone();
    d = cv::Mat(guess->distortion_coefficients, true).reshape(1, 1);
    flags |= isFisheye(model) ? static_cast<int>(cv::fisheye::CALIB_USE_INTRINSIC_GUESS)
                              : static_cast<int>(cv::CALIB_USE_INTRINSIC_GUESS);
  }
  // OpenCV's default (30 iterations, DBL_EPSILON) for the plain baseline; otherwise stop at a
  // relative change of 1e-7 (fx moves by under 1e-4 px), which is several times faster. The
  // joint fits' iterations are cheap, and from a start far off a poorly pinned term (k3 of a wide
  // lens from camera_info's matrix) needs more of them than OpenCV's solver: 57 where 50 left
  // the RMS at 0.153 px for 0.130.
  const cv::TermCriteria criteria =
      opencv_default_criteria
          ? cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, DBL_EPSILON)
          : cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 300, 1e-7);
  std::vector<bool> fisheye_fitted;  // the free parameters of a fisheye fit
  try {
    if (isFisheye(model)) {
      if (d.empty()) d = cv::Mat::zeros(4, 1, CV_64F);
      d = d.reshape(1, 4);
      std::vector<std::vector<cv::Point3d>> obj_d;
      std::vector<std::vector<cv::Point2d>> img_d;
      for (const auto& o : obj) obj_d.emplace_back(o.begin(), o.end());
      for (const auto& i : img) img_d.emplace_back(i.begin(), i.end());
      f.rms_px = fisheyeCalibrate(obj_d, img_d, size, k, d, f.rvecs, f.tvecs, flags, criteria);
      fisheye_fitted = {true, true, true, true, true, true,
                        !(flags & cv::fisheye::CALIB_FIX_K3), !(flags & cv::fisheye::CALIB_FIX_K4)};
    } else if (opencv_default_criteria) {
      cv::Mat std_int, std_ext, per_view;
      f.rms_px = cv::calibrateCamera(obj, img, size, k, d, f.rvecs, f.tvecs, std_int, std_ext,
                                     per_view, flags, criteria);
      f.std_devs = {std_int.at<double>(0), std_int.at<double>(1), std_int.at<double>(2),
                    std_int.at<double>(3)};
      for (size_t i = 0; i < distortionCount(model); ++i)
        f.std_devs.push_back(std_int.at<double>(4 + static_cast<int>(i)));
    } else {
      // cv::calibrateCamera's fit with the poses eliminated in each step (joint_fit.h).
      const JointFit p = fitPinhole(obj, img, size, k, d, f.rvecs, f.tvecs, flags, criteria);
      f.rms_px = p.rms_px;
      f.std_devs = p.std_devs;
    }
  } catch (const cv::Exception& e) {
    throw CalibrationError(std::string("OpenCV could not fit the model: ") + e.what());
  }
  f.intrinsics.setCameraMatrix(cv::Matx33d(k));
  d = d.reshape(1, 1);
  f.intrinsics.distortion_coefficients.assign(distortionCount(model), 0.0);
  for (int i = 0; i < std::min<int>(d.cols, static_cast<int>(distortionCount(model))); ++i) {
    f.intrinsics.distortion_coefficients[static_cast<size_t>(i)] = d.at<double>(i);
  }
  if (!fisheye_fitted.empty()) {
    // The fisheye fit reports no standard deviations: the covariance at its result gives them (over repeated synthetic fits, its results scatter as that covariance
    // says: CameraUncertainty.FisheyePredictionMatchesRepeatedCalibrations).
    f.covariance = intrinsicsCovariance(obj, img, f.rvecs, f.tvecs, f.intrinsics, fisheye_fitted);
    f.std_devs = f.covariance.std_devs(fisheye_fitted.size());
  }
  const CameraIntrinsics& in = f.intrinsics;
  if (!std::isfinite(in.fx) || !std::isfinite(in.fy) || !std::isfinite(in.cx) ||
      !std::isfinite(in.cy)) {
    throw CalibrationError("the fit diverged (non-finite camera matrix)");
  }
  return f;
}

Points2 project(const Points3& obj, const cv::Mat& rvec, const cv::Mat& tvec,
                const CameraIntrinsics& in) {
  Points2 out;
  if (isFisheye(in.distortion_model)) {
    cv::fisheye::projectPoints(obj, out, rvec, tvec, cv::Mat(in.cameraMatrix()),
                               cv::Mat(in.distortion_coefficients));
  } else {
    cv::projectPoints(obj, rvec, tvec, cv::Mat(in.cameraMatrix()),
                      cv::Mat(in.distortion_coefficients), out);
  }
  return out;
}

double rms(const Points2& a, const Points2& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const cv::Point2f d = a[i] - b[i];
    s += d.x * d.x + d.y * d.y;
  }
  return a.empty() ? 0 : std::sqrt(s / static_cast<double>(a.size()));
}

double heldOut(const Points3& obj, const Points2& img, const CameraIntrinsics& in) {
  cv::Mat rvec, tvec;
  try {
    if (isFisheye(in.distortion_model)) {
      Points2 normalised;
      cv::fisheye::undistortPoints(img, normalised, cv::Mat(in.cameraMatrix()),
                                   cv::Mat(in.distortion_coefficients));
      cv::solvePnP(obj, normalised, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec);
    } else {
      cv::solvePnP(obj, img, cv::Mat(in.cameraMatrix()), cv::Mat(in.distortion_coefficients), rvec,
                   tvec);
    }
    return rms(project(obj, rvec, tvec, in), img);
  } catch (const cv::Exception& e) {
    throw CalibrationError(std::string("OpenCV could not fit a held-out view's pose: ") + e.what());
  }
}

// Mean held-out RMS over folds (leave-one-out up to max_folds views).
double crossValidate(const std::vector<Points3>& obj, const std::vector<Points2>& img,
                     const cv::Size& size, DistortionModel model, int flags, int max_folds,
                     const CameraIntrinsics* guess) {
  const int n = static_cast<int>(obj.size());
  const int folds = std::min(n, max_folds);
  const Fit all = fit(obj, img, size, model, flags, guess);
  double sum = 0;
  int count = 0;
  for (int fold = 0; fold < folds; ++fold) {
    std::vector<Points3> o;
    std::vector<Points2> i;
    for (int v = 0; v < n; ++v) {
      if (v % folds == fold) continue;
      o.push_back(obj[static_cast<size_t>(v)]);
      i.push_back(img[static_cast<size_t>(v)]);
    }
    const Fit f = fit(o, i, size, model, flags, &all.intrinsics);
    for (int v = fold; v < n; v += folds) {
      sum += heldOut(obj[static_cast<size_t>(v)], img[static_cast<size_t>(v)], f.intrinsics);
      ++count;
    }
  }
  return sum / std::max(1, count);
}

/// The fits of every other view against the rest (HalvesCrossValidation), started from `all`.
HalvesCrossValidation crossValidateHalves(const std::vector<Points3>& obj,
                                          const std::vector<Points2>& img, const cv::Size& size,
                                          DistortionModel model, int flags,
                                          const std::vector<bool>& fitted,
                                          const CameraIntrinsics& all,
                                          const ProjectionUncertainty& all_uncertainty) {
  HalvesCrossValidation out;
  if (obj.size() < 8 || !all_uncertainty.valid) return out;
  std::vector<Points3> obj_half[2];
  std::vector<Points2> img_half[2];
  for (size_t v = 0; v < obj.size(); ++v) {
    obj_half[v % 2].push_back(obj[v]);
    img_half[v % 2].push_back(img[v]);
  }
  Fit half[2];
  ProjectionUncertainty u[2];
  try {
    for (int h = 0; h < 2; ++h) {
      half[h] = fit(obj_half[h], img_half[h], size, model, flags, &all);
      u[h] = uncertaintyOf(half[h], obj_half[h], img_half[h], fitted, all_uncertainty.grid);
    }
  } catch (const CalibrationError&) {
    return out;  // a half too weak to fit: no cross-validation
  }
  if (!u[0].valid || !u[1].valid) return out;
  const std::vector<double> d =
      projectionDifferences(half[0].intrinsics, half[1].intrinsics, all_uncertainty.grid);
  double sum = 0, expected = 0, normalised = 0;
  int n = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    if (!std::isfinite(d[i])) continue;
    // Against the corners' noise alone: the views' scatter is what a misfit shows as.
    const double a = u[0].independent_sigma_px[i], b = u[1].independent_sigma_px[i];
    const double variance = a * a + b * b;
    if (!(variance > 0)) continue;
    sum += d[i] * d[i];
    expected += variance;
    normalised += d[i] * d[i] / variance;
    out.worst_px = std::max(out.worst_px, d[i]);
    ++n;
  }
  if (n == 0) return out;
  out.views_each = static_cast<int>(obj_half[1].size());
  out.rms_px = std::sqrt(sum / n);
  out.expected_rms_px = std::sqrt(expected / n);
  out.ratio = std::sqrt(normalised / n);
  out.valid = true;
  return out;
}

std::string fmt(const char* format, double a, double b = 0, double c = 0) {
  char buf[200];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

}  // namespace

CalibrationResult calibrate(const std::vector<std::vector<cv::Point2f>>& views,
                            const cv::Size& image_size, const BoardSpec& board_spec,
                            const CalibrationOptions& options) {
  const size_t n_corners = static_cast<size_t>(board_spec.cornerCount());
  std::optional<CameraIntrinsics> start;
  if (options.initial_camera_matrix) {
    const cv::Matx33d& k = *options.initial_camera_matrix;
    if (!(std::isfinite(k(0, 0)) && std::isfinite(k(1, 1)) && std::isfinite(k(0, 2)) &&
          std::isfinite(k(1, 2)) && k(0, 0) > 0 && k(1, 1) > 0))
      throw InputError("initial camera matrix: fx, fy must be finite and > 0, cx, cy finite");
    start.emplace();
    start->distortion_model = options.model;
    start->setImageSize(image_size);
    start->setCameraMatrix(k);
    start->distortion_coefficients.assign(distortionCount(options.model), 0.0);
  }
  const CameraIntrinsics* guess = start ? &*start : nullptr;
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].size() != n_corners) {
      throw InputError("view " + std::to_string(v) + " has " + std::to_string(views[v].size()) +
                       " corners, the board has " + std::to_string(n_corners));
    }
    for (size_t c = 0; c < views[v].size(); ++c) {
      if (!std::isfinite(views[v][c].x) || !std::isfinite(views[v][c].y)) {
        throw InputError("view " + std::to_string(v) + ": corner " + std::to_string(c) +
                         " is NaN or infinite");
      }
    }
  }
  if (static_cast<int>(views.size()) < options.min_views) {
    throw CalibrationError("too few views: " + std::to_string(views.size()) + " < " +
                           std::to_string(options.min_views) + " (show the board in more poses)");
  }
  // All views alike (one pose seen again and again): the focal length and the distance along
  // the optical axis cannot be told apart, whatever the fit reports.
  {
    const ViewSelectionOptions sel;
    std::array<double, 6> lo, hi;
    lo.fill(1e9);
    hi.fill(-1e9);
    for (const auto& v : views) {
      const auto a = computeViewParams(v, image_size, board_spec, sel).asArray();
      for (size_t k = 0; k < 6; ++k) {
        lo[k] = std::min(lo[k], a[k]);
        hi[k] = std::max(hi[k], a[k]);
      }
    }
    const double spread_xy = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    const double spread_size = hi[2] - lo[2], spread_skew = hi[3] - lo[3],
                 spread_tilt = hi[5] - lo[5];
    if (std::max({spread_xy, spread_size, spread_skew, spread_tilt}) < options.min_param_spread) {
      throw CalibrationError(
          fmt("views all alike: position spread %.3f, size spread %.3f, skew spread %.3f",
              spread_xy, spread_size, spread_skew) +
          fmt(", tilt spread %.3f (< %.3f each); move or tilt the board between views", spread_tilt,
              options.min_param_spread));
    }
  }

  const Points3 board = board_spec.points();
  const std::vector<TermSet> sets = termSets(options.model);
  // Outliers are judged with the middle term set: flexible enough for real lenses, too stiff to
  // absorb a bad view.
  const TermSet& judge_set = sets[1];  // judge_level below
  // The richest set fitted (max_term_set).
  const size_t top_level =
      options.max_term_set >= 0
          ? std::min(sets.size() - 1, static_cast<size_t>(options.max_term_set))
          : sets.size() - 1;

  std::vector<int> active(views.size());
  std::iota(active.begin(), active.end(), 0);
  std::vector<std::vector<char>> keep(views.size(), std::vector<char>(n_corners, 1));
  CalibrationResult result;
  auto gather = [&](std::vector<Points3>& obj, std::vector<Points2>& img) {
    obj.clear();
    img.clear();
    for (int v : active) {
      Points3 o;
      Points2 i;
      for (size_t c = 0; c < n_corners; ++c) {
        if (!keep[static_cast<size_t>(v)][c]) continue;
        o.push_back(board[c]);
        i.push_back(views[static_cast<size_t>(v)][c]);
      }
      obj.push_back(o);
      img.push_back(i);
    }
  };
  std::vector<Points3> obj;
  std::vector<Points2> img;
  const size_t min_active =
      std::max<size_t>(static_cast<size_t>(options.min_views),
                       static_cast<size_t>(std::ceil(options.min_kept_fraction *
                                                     static_cast<double>(views.size()))));
  // The judging fit of the last round, when that round dropped nothing: it is then the fit of
  // the judging term set on the final data, and the term selection below reuses it.
  std::optional<Fit> judge_fit;
  const size_t judge_level = 1;
  // Every fit after the first starts where the last judging fit ended (a warm start: the same
  // optimum in far fewer iterations), with the terms the new set holds fixed put back at 0.
  std::optional<CameraIntrinsics> warm;
  std::vector<CameraIntrinsics> starts(sets.size());
  const auto startFor = [&](size_t level) -> const CameraIntrinsics* {
    if (!warm) return guess;
    CameraIntrinsics& s = starts[level];
    s = *warm;
    std::vector<char> fitted(s.distortion_coefficients.size(), 0);
    for (size_t l = 0; l <= level; ++l)
      for (int i : sets[l].added) fitted[static_cast<size_t>(i)] = 1;
    for (size_t i = 0; i < fitted.size(); ++i)
      if (!fitted[i]) s.distortion_coefficients[i] = 0;
    return &s;
  };
  for (int round = 0; round < options.max_outlier_rounds; ++round) {
    gather(obj, img);
    const Fit f = fit(obj, img, image_size, options.model, judge_set.flags, startFor(judge_level));
    warm = f.intrinsics;
    judge_fit.reset();
    // Residuals of every corner; a corner is an outlier beyond a limit set by the median view
    // (robust to the outliers themselves). A view is an outlier when too many of its corners
    // are, or when its inlier corners still fit badly (a wrong match, a moved board).
    std::vector<Points2> projected(active.size());
    std::vector<std::vector<double>> residual(active.size());
    std::vector<double> all_rms(active.size());
    for (size_t a = 0; a < active.size(); ++a) {
      projected[a] = project(obj[a], f.rvecs[a], f.tvecs[a], f.intrinsics);
      all_rms[a] = rms(projected[a], img[a]);
      for (size_t j = 0; j < img[a].size(); ++j)
        residual[a].push_back(cv::norm(projected[a][j] - img[a][j]));
    }
    std::vector<double> sorted = all_rms;
    std::nth_element(sorted.begin(),
                     sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    const double view_limit =
        std::max(options.outlier_view_factor * median, options.outlier_view_min_px);
    const double corner_limit =
        std::max(options.outlier_corner_factor * median, options.outlier_corner_min_px);
    std::vector<double> inlier_rms(active.size());
    std::vector<double> outlier_fraction(active.size());
    for (size_t a = 0; a < active.size(); ++a) {
      double s = 0;
      int inliers = 0;
      for (double r : residual[a]) {
        if (r <= corner_limit) {
          s += r * r;
          ++inliers;
        }
      }
      inlier_rms[a] = inliers ? std::sqrt(s / inliers) : std::numeric_limits<double>::infinity();
      outlier_fraction[a] =
          1.0 - static_cast<double>(inliers) / static_cast<double>(residual[a].size());
    }
    auto badness = [&](size_t a) {
      return outlier_fraction[a] > options.max_outlier_corner_fraction ? 1e9 + outlier_fraction[a]
                                                                       : inlier_rms[a];
    };
    // Worst views first, never below the minimum number of views.
    std::vector<size_t> order(active.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return badness(a) > badness(b); });
    std::vector<char> drop(active.size(), 0);
    size_t remaining = active.size();
    bool changed = false;
    for (size_t a : order) {
      const bool too_many = outlier_fraction[a] > options.max_outlier_corner_fraction;
      if (!too_many && inlier_rms[a] <= view_limit) break;
      if (remaining <= min_active) {
        throw CalibrationError(
            fmt("too many outlier views: view RMS up to %.2f px against a median of %.2f px",
                all_rms[order[0]], median) +
            "; " + std::to_string(active.size()) + " views left, at least " +
            std::to_string(min_active) + " needed");
      }
      drop[a] = 1;
      --remaining;
      result.dropped_views.push_back(
          {active[a], too_many
                          ? fmt("outlier view: %.0f %% of its corners off by more than %.2f px",
                                100 * outlier_fraction[a], corner_limit)
                          : fmt("outlier view: RMS %.2f px > %.2f px (%.1f x median)",
                                inlier_rms[a], view_limit, options.outlier_view_factor)});
      changed = true;
    }
    for (size_t a = 0; a < active.size(); ++a) {
      if (drop[a]) continue;
      // Indices of kept corners of this view, in order, to map residuals back.
      const int v = active[a];
      size_t j = 0;
      for (size_t c = 0; c < n_corners; ++c) {
        if (!keep[static_cast<size_t>(v)][c]) continue;
        if (residual[a][j] > corner_limit) {
          keep[static_cast<size_t>(v)][c] = 0;
          ++result.dropped_corners;
          changed = true;
        }
        ++j;
      }
    }
    std::vector<int> next;
    for (size_t a = 0; a < active.size(); ++a) {
      if (!drop[a]) next.push_back(active[a]);
    }
    active = next;
    if (!changed) {
      judge_fit = f;
      break;
    }
  }
  gather(obj, img);

  TermSet chosen = sets[top_level];
  size_t chosen_level = top_level;
  static const char* kTermNames[3][8] = {{"k1", "k2", "p1", "p2", "k3", "", "", ""},
                                         {"k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"},
                                         {"k1", "k2", "k3", "k4", "", "", "", ""}};
  const auto term_name = [&](int i) {
    return std::string(kTermNames[static_cast<int>(options.model)][i]);
  };
  std::optional<Fit> final_fit;
  if (options.select_distortion_terms &&
      options.selection == CalibrationOptions::Selection::kSignificance) {
    // Drop the most complex group of terms while none of its terms stands out of its own
    // uncertainty: such a term fits the noise of these views, not the lens (ROS's fits
    // swing by 15 px in fx between folds of 13 photos).
    size_t level = top_level;
    Fit f = fit(obj, img, image_size, options.model, sets[level].flags, startFor(level));
    const auto fitLevel = [&](size_t l) {
      return (l == judge_level && judge_fit)
                 ? *judge_fit
                 : fit(obj, img, image_size, options.model, sets[l].flags, startFor(l));
    };
    while (level > 0) {
      // The simpler model nests in this one, so at the optimum this one's RMS is lower. When it
      // is not, the optimiser has run off along a valley the views do not constrain (boards all
      // at one height in the image trade fx against the radial terms: +14 % fx in the
      // simulator's pivot scene), and the added terms' small standard deviations mean nothing.
      Fit simpler = fitLevel(level - 1);
      bool significant = false;
      std::string why, verdict = fmt(": fixed at 0 (t < %.1f)", options.min_term_significance);
      if (f.rms_px >= simpler.rms_px) {
        why = sets[level].name +
              fmt(" does not lower the RMS (%.4f px, without: %.4f px)", f.rms_px, simpler.rms_px);
        verdict = ": its added terms fixed at 0";
      } else {
        for (int i : sets[level].added) {
          const double value = f.intrinsics.distortion_coefficients[static_cast<size_t>(i)];
          const double sigma = f.std_devs[4 + static_cast<size_t>(i)];
          const double t =
              sigma > 0 ? std::abs(value) / sigma : std::numeric_limits<double>::infinity();
          significant = significant || t >= options.min_term_significance;
          why += (why.empty() ? "" : ", ") + term_name(i) +
                 fmt(" = %.4g +- %.2g (t %.1f)", value, sigma, t);
        }
        // Terms that trade against each other along a valley (rational_polynomial's k4..k6, the
        // denominator's, against k1..k3 and each other) each have a large standard deviation even
        // where together they are what the lens needs: a rational lens's corners, 0.136 px RMS with them fixed and
        // 0.076 px with them free, with t 0.1-0.2 each. So a group is kept too when it lowers
        // the RMS by more than model_rms_margin (beyond what explains the corners equally well)
        // and the corners' chi-square by more than its terms at min_term_significance each would.
        const size_t terms = sets[level].added.size();
        if (!significant && terms > 1) {
          size_t corners = 0;
          for (const auto& view : img) corners += view.size();
          size_t distortion_terms = 0;
          for (size_t l = 0; l <= level; ++l) distortion_terms += sets[l].added.size();
          const double free =
              6.0 * static_cast<double>(img.size()) + 4.0 + static_cast<double>(distortion_terms);
          const double residuals = 2.0 * static_cast<double>(corners);
          const double variance =
              f.rms_px * f.rms_px * static_cast<double>(corners) / std::max(1.0, residuals - free);
          const double chi2_drop = static_cast<double>(corners) *
                                   (simpler.rms_px * simpler.rms_px - f.rms_px * f.rms_px) /
                                   std::max(variance, 1e-300);
          const double min_chi2 = static_cast<double>(terms) * options.min_term_significance *
                                  options.min_term_significance;
          if (f.rms_px < simpler.rms_px / (1 + options.model_rms_margin) && chi2_drop >= min_chi2) {
            significant = true;
            why += fmt("; together they lower the RMS from %.4f to %.4f px (chi-square by %.0f)",
                       simpler.rms_px, f.rms_px, chi2_drop);
          }
        }
      }
      result.selection_reason +=
          (result.selection_reason.empty() ? "" : "; ") + why + (significant ? ": kept" : verdict);
      if (significant) break;
      --level;
      f = std::move(simpler);
    }
    chosen = sets[level];
    chosen_level = level;
    final_fit = f;
  } else if (options.select_distortion_terms) {
    // The simplest term set whose held-out error is within the margin of the best one. A term
    // the views cannot constrain lowers the training RMS and raises the error on unseen views.
    std::vector<double> scores;
    for (size_t i = 0; i <= top_level; ++i) {
      scores.push_back(crossValidate(obj, img, image_size, options.model, sets[i].flags,
                                     options.max_selection_folds, guess));
    }
    const double best = *std::min_element(scores.begin(), scores.end());
    for (size_t i = 0; i <= top_level; ++i) {
      result.selection_reason +=
          (i ? "; " : "") + sets[i].name + fmt(": held-out %.4f px", scores[i]);
    }
    for (size_t i = 0; i <= top_level; ++i) {
      if (scores[i] <= best * (1 + options.selection_margin)) {
        chosen = sets[i];
        chosen_level = i;
        result.selection_holdout_rms_px = scores[i];
        break;
      }
    }
  }
  const Fit f =
      final_fit ? *final_fit
                : fit(obj, img, image_size, options.model, chosen.flags, startFor(chosen_level));
  result.intrinsics = f.intrinsics;
  result.rms_px = f.rms_px;
  result.std_devs = f.std_devs;
  result.fitted_terms = chosen.name;
  result.term_set = static_cast<int>(chosen_level);
  result.used_views = active;
  const Points3 every_corner = board_spec.points();
  double all_squared = 0;
  size_t all_count = 0;
  for (size_t a = 0; a < active.size(); ++a) {
    result.per_view_rms_px.push_back(
        rms(project(obj[a], f.rvecs[a], f.tvecs[a], f.intrinsics), img[a]));
    // Each corner counted up to model_corner_cap_factor times the fit's RMS: a corner detected
    // wrong (a board cut by the image edge: 11.6 px off the true lens's fit) weighs about the same
    // for every model, so a model cannot win by bending towards it (an equidistant fit of a
    // plumb_bob lens explained such a corner at 2.6 px and was written 4.2 px off over the image).
    const Points2 projected = project(every_corner, f.rvecs[a], f.tvecs[a], f.intrinsics);
    const Points2& seen = views[static_cast<size_t>(active[a])];
    const double cap_px = options.model_corner_cap_factor * f.rms_px;
    for (size_t c = 0; c < projected.size(); ++c) {
      const double e = std::min(cv::norm(projected[c] - seen[c]), cap_px);
      all_squared += e * e;
      ++all_count;
    }
  }
  result.all_corners_rms_px =
      all_count ? std::sqrt(all_squared / static_cast<double>(all_count)) : 0;
  // The free parameters: those with a standard deviation (a fixed one has 0).
  std::vector<bool> fitted;
  for (const double s : f.std_devs) fitted.push_back(s > 0);
  if (!options.judge_whole_image) return result;
  result.uncertainty = uncertaintyOf(f, obj, img, fitted);
  result.halves = crossValidateHalves(obj, img, image_size, options.model, chosen.flags, fitted,
                                      f.intrinsics, result.uncertainty);
  return result;
}

HoldoutEvaluation leaveOneOut(const std::vector<std::vector<cv::Point2f>>& views,
                              const cv::Size& image_size, const BoardSpec& board_spec,
                              const CalibrationOptions& options, HoldoutMethod method) {
  HoldoutEvaluation e;
  const Points3 board = board_spec.points();
  for (size_t held = 0; held < views.size(); ++held) {
    std::vector<Points2> train;
    for (size_t v = 0; v < views.size(); ++v) {
      if (v != held) train.push_back(views[v]);
    }
    CameraIntrinsics in;
    if (method == HoldoutMethod::kAutocal) {
      in = calibrate(train, image_size, board_spec, options).intrinsics;
    } else {
      const std::vector<Points3> obj(train.size(), board);
      in = fit(obj, train, image_size, DistortionModel::kPlumbBob, 0, nullptr, true).intrinsics;
    }
    e.fold_rms_px.push_back(heldOut(board, views[held], in));
    e.fold_fx_px.push_back(in.fx);
  }
  if (!views.empty()) {
    e.mean_rms_px = std::accumulate(e.fold_rms_px.begin(), e.fold_rms_px.end(), 0.0) /
                    static_cast<double>(views.size());
    const auto mm = std::minmax_element(e.fold_fx_px.begin(), e.fold_fx_px.end());
    e.fx_spread_px = *mm.second - *mm.first;
  }
  return e;
}

namespace {

/// The gate's cross-validation: the two halves' fits differ by more than their uncertainty allows.
bool halvesDisagree(const CalibrationResult& r, const QualityGateOptions& gate) {
  return r.halves.valid && r.halves.views_each >= gate.min_views_per_half &&
         !(r.halves.ratio <= gate.max_halves_ratio);
}

}  // namespace

std::vector<std::string> checkQuality(const CalibrationResult& r, const QualityGateOptions& gate) {
  std::vector<std::string> reasons;
  if (!(r.rms_px <= gate.max_rms_px)) {
    reasons.push_back(fmt("RMS reprojection error %.3f px > %.3f px", r.rms_px, gate.max_rms_px));
  }
  for (size_t i = 0; i < r.per_view_rms_px.size(); ++i) {
    if (!(r.per_view_rms_px[i] <= gate.max_view_rms_px)) {
      reasons.push_back("view " + std::to_string(r.used_views[i]) +
                        fmt(": RMS %.3f px > %.3f px", r.per_view_rms_px[i], gate.max_view_rms_px));
    }
  }
  if (static_cast<int>(r.used_views.size()) < gate.min_views) {
    reasons.push_back("only " + std::to_string(r.used_views.size()) + " views used, need " +
                      std::to_string(gate.min_views));
  }
  if (r.std_devs.size() >= 2) {
    const double rel = std::max(r.std_devs[0] / r.intrinsics.fx, r.std_devs[1] / r.intrinsics.fy);
    if (!(rel <= gate.max_focal_rel_std)) {
      reasons.push_back(fmt("focal length uncertain: std dev %.2f %% > %.2f %%", 100 * rel,
                            100 * gate.max_focal_rel_std));
    }
  }
  const cv::Size s = r.intrinsics.imageSize();
  const double dx = std::abs(r.intrinsics.cx - s.width / 2.0) / s.width;
  const double dy = std::abs(r.intrinsics.cy - s.height / 2.0) / s.height;
  if (!(std::max(dx, dy) <= gate.max_principal_offset_ratio)) {
    reasons.push_back(fmt("principal point (%.1f, %.1f) px too far from the image centre",
                          r.intrinsics.cx, r.intrinsics.cy) +
                      fmt(" (> %.0f %% of the image size)", 100 * gate.max_principal_offset_ratio));
  }
  if (!(r.intrinsics.fx > 0 && r.intrinsics.fy > 0)) reasons.push_back("focal length not positive");
  // The whole image, from the uncertainty and the cross-validation.
  const ProjectionUncertainty& u = r.uncertainty;
  if (u.valid && u.unmapped > 0) {
    reasons.push_back("the fitted model maps no ray to " + std::to_string(u.unmapped) + " of the " +
                      std::to_string(u.grid.cells()) +
                      " cells of the image grid: it extrapolates far beyond the views there; add "
                      "views whose board corners reach those parts of the image");
  }
  if (u.valid && !(u.lower_half_worst_px <= gate.max_lower_half_uncertainty_px)) {
    reasons.push_back(
        fmt("the lower half of the image is not pinned down by the views: projection uncertainty "
            "up to %.2f px there (limit %.2f px)",
            u.lower_half_worst_px, gate.max_lower_half_uncertainty_px) +
        "; the boards were seen too high in the image: add boards the camera sees low in its "
        "image (nearer the robot, lower, or lying on the floor)");
  }
  if (halvesDisagree(r, gate)) {
    reasons.push_back(
        fmt("two calibrations from alternate halves of the views differ by %.2f px RMS, %.1f "
            "times what their uncertainty allows (limit %.1f)",
            r.halves.rms_px, r.halves.ratio, gate.max_halves_ratio) +
        ": the lens model (" + distortionModelName(r.intrinsics.distortion_model) + ", terms " +
        r.fitted_terms +
        ") does not fit this lens, or the lens moved during the sweep (focus ring, a knock); try "
        "another distortion_model (rational_polynomial; equidistant for a fisheye lens)");
  }
  return reasons;
}

std::string ModelChoice::refusals(const std::string& separator) const {
  std::string out;
  for (const Refusal& r : refused) {
    if (!out.empty()) out += separator;
    if (refused.size() > 1) out += distortionModelName(r.model) + ": ";
    for (size_t k = 0; k < r.reasons.size(); ++k) out += (k ? separator : "") + r.reasons[k];
  }
  return out;
}

namespace {

/// How far `fit` projects from `reference` over `grid`, and the radius around the image centre
/// within which it stays within `limit_px` of it.
struct ModelDifference {
  double rms_px = 0, worst_px = 0;
  double valid_radius_px = 0;  ///< the nearest grid cell beyond the limit (or none unmapped)
  double valid_fraction = 0;   ///< of the grid's cells within that radius
};
ModelDifference modelDifference(const CameraIntrinsics& fit, const CameraIntrinsics& reference,
                                double limit_px, const ImageGrid& grid) {
  const std::vector<double> d = projectionDifferences(reference, fit, grid);
  const std::vector<cv::Point2d> centres = grid.centres(fit.width, fit.height);
  ModelDifference out;
  out.valid_radius_px = std::hypot(fit.width, fit.height);
  std::vector<double> radius;
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < centres.size(); ++i) {
    const double e = d[i];
    radius.push_back(std::hypot(centres[i].x - 0.5 * fit.width, centres[i].y - 0.5 * fit.height));
    if (!(e <= limit_px)) out.valid_radius_px = std::min(out.valid_radius_px, radius.back());
    if (!std::isfinite(e)) {
      out.worst_px = std::numeric_limits<double>::infinity();
      continue;
    }
    sum += e * e;
    ++n;
    out.worst_px = std::max(out.worst_px, e);
  }
  out.rms_px = n ? std::sqrt(sum / n) : std::numeric_limits<double>::infinity();
  out.valid_fraction =
      static_cast<double>(std::count_if(radius.begin(), radius.end(),
                                        [&](double r) { return r < out.valid_radius_px; })) /
      static_cast<double>(radius.size());
  return out;
}

/// A view the rest disagree with (CalibrationOptions::halves_outlier_view_factor): while the
/// halves of the views disagree, the view with the largest RMS, if it is that many times the
/// median view's, is left out and the model refitted (its terms chosen again); the first refit the
/// gate passes replaces `result`, with the views left out among its dropped views.
void dropViewsTheHalvesDisagreeOver(const std::vector<std::vector<cv::Point2f>>& views,
                                    const cv::Size& image_size, const BoardSpec& board,
                                    const CalibrationOptions& options,
                                    const QualityGateOptions& gate, CalibrationResult* result,
                                    std::vector<std::string>* reasons) {
  std::vector<DroppedView> left_out;
  CalibrationResult current = *result;
  for (int n = 0; n < options.max_halves_outlier_views && halvesDisagree(current, gate); ++n) {
    const std::vector<double>& rms = current.per_view_rms_px;
    if (rms.size() < 2) return;
    const size_t worst =
        static_cast<size_t>(std::max_element(rms.begin(), rms.end()) - rms.begin());
    std::vector<double> sorted = rms;
    std::nth_element(sorted.begin(),
                     sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    if (!(rms[worst] >= options.halves_outlier_view_factor * median)) return;
    left_out.push_back(
        {current.used_views[worst],
         fmt("a view the others disagree with: RMS %.3f px, %.1f x the median view; with it the "
             "halves of the views differed %.1f times their uncertainty",
             rms[worst], rms[worst] / median, current.halves.ratio) +
             fmt(" (limit %.1f)", gate.max_halves_ratio)});
    std::vector<std::vector<cv::Point2f>> kept;
    std::vector<int> original;
    for (size_t v = 0; v < views.size(); ++v) {
      const bool out = std::any_of(left_out.begin(), left_out.end(), [&](const DroppedView& d) {
        return d.index == static_cast<int>(v);
      });
      if (out) continue;
      kept.push_back(views[v]);
      original.push_back(static_cast<int>(v));
    }
    try {
      current = calibrate(kept, image_size, board, options);
    } catch (const CalibrationError&) {
      return;
    }
    for (int& u : current.used_views) u = original[static_cast<size_t>(u)];
    for (DroppedView& d : current.dropped_views) d.index = original[static_cast<size_t>(d.index)];
    if (!checkQuality(current, gate).empty()) continue;
    current.dropped_views.insert(current.dropped_views.end(), left_out.begin(), left_out.end());
    std::string which;
    for (const DroppedView& d : left_out)
      which += (which.empty() ? "" : ", ") + std::to_string(d.index);
    current.selection_reason = "view(s) " + which +
                               " left out: the halves of the views disagreed with them; " +
                               current.selection_reason;
    *result = std::move(current);
    reasons->clear();
    return;
  }
}

}  // namespace

bool muchSurer(const ProjectionUncertainty& candidate, const ProjectionUncertainty& current,
               double margin) {
  if (!candidate.valid) return false;
  if (!current.valid) return true;
  return candidate.rms_px < current.rms_px * (1 - margin) ||
         (candidate.worst_px < current.worst_px * std::min(1 - margin, 0.5) &&
          candidate.rms_px <= current.rms_px);
}

ModelChoice calibrateChoosingModel(const std::vector<std::vector<cv::Point2f>>& views,
                                   const cv::Size& image_size, const BoardSpec& board,
                                   const CalibrationOptions& options,
                                   const QualityGateOptions& gate) {
  // The listed models in their order, then the others as references: a listed model may be
  // written only where it projects as the model that fits best does.
  std::vector<DistortionModel> models{options.model};
  for (const DistortionModel m : options.fallback_models)
    if (std::find(models.begin(), models.end(), m) == models.end()) models.push_back(m);
  const size_t listed = models.size();
  for (const DistortionModel m : {DistortionModel::kPlumbBob, DistortionModel::kRationalPolynomial,
                                  DistortionModel::kEquidistant})
    if (std::find(models.begin(), models.end(), m) == models.end()) models.push_back(m);
  std::vector<CalibrationResult> result(models.size());
  std::vector<char> fitted(models.size(), 0);  // not vector<bool>: set from several threads
  std::vector<std::vector<std::string>> reasons(models.size());
  // Each model on its own thread (CalibrationOptions::threads): a model's fits use nothing of
  // another's, so the choice is the same as fitted one after the other.
  forEachIndex(models.size(), options.threads, [&](size_t k) {
    CalibrationOptions o = options;
    o.model = models[k];
    try {
      result[k] = calibrate(views, image_size, board, o);
      fitted[k] = 1;
    } catch (const CalibrationError& e) {
      if (k == 0) throw;  // the views themselves cannot determine a model
      reasons[k] = {std::string("the fit failed: ") + e.what()};
      return;
    }
    reasons[k] = checkQuality(result[k], gate);
    // A term the significance kept on all views may be one the halves of them disagree on: it
    // fits a bias the views share, not the lens, and swings where no board was seen (the wide
    // plumb_bob lens's k3 in one run of ten: t >= 3 on all views, the halves 9.7 times their
    // uncertainty apart; k3 was 0). The simpler term sets are tried, and the first the gate passes
    // that explains the corners within model_rms_margin as well replaces it.
    for (int level = result[k].term_set - 1;
         options.select_distortion_terms && level >= 0 && halvesDisagree(result[k], gate);
         --level) {
      CalibrationOptions simpler = o;
      simpler.max_term_set = level;
      CalibrationResult r;
      try {
        r = calibrate(views, image_size, board, simpler);
      } catch (const CalibrationError&) {
        break;
      }
      // Only a set that explains the corners as well: fixing a term the lens has (the wide lens's
      // p1 p2, 0.004) passed the halves in one run at 0.365 px RMS for 0.087, 4-6 px off in cx.
      if (!(r.all_corners_rms_px <= result[k].all_corners_rms_px * (1 + options.model_rms_margin)))
        break;
      if (!checkQuality(r, gate).empty()) continue;
      r.selection_reason = result[k].fitted_terms +
                           fmt(": its halves differed %.1f times their uncertainty (limit %.1f), "
                               "a simpler set taken; ",
                               result[k].halves.ratio, gate.max_halves_ratio) +
                           r.selection_reason;
      result[k] = std::move(r);
      reasons[k].clear();
    }
    if (!reasons[k].empty() && halvesDisagree(result[k], gate))
      dropViewsTheHalvesDisagreeOver(views, image_size, board, o, gate, &result[k], &reasons[k]);
  });
  const auto passes = [&](size_t k) { return fitted[k] && reasons[k].empty(); };
  const auto sureness = [&](size_t k) {
    return result[k].uncertainty.valid ? result[k].uncertainty.rms_px
                                       : std::numeric_limits<double>::infinity();
  };
  const auto worstSureness = [&](size_t k) {
    return result[k].uncertainty.valid ? result[k].uncertainty.worst_px
                                       : std::numeric_limits<double>::infinity();
  };
  // The best of models [0, end): of those the gate passes and that explain the corners within
  // model_rms_margin as well as the best of them, the first unless a later one is much surer.
  // (The halves' cross-validation judges in the gate only: between two models that both pass,
  // its ratio is noise: the simulator's narrow plumb_bob lens had 2.1 with plumb_bob and 1.4 with
  // equidistant, whose fit was 3.5 px off in cx.)
  const auto best = [&](size_t end, double* lowest_rms) {
    double lowest = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < end; ++k)
      if (passes(k)) lowest = std::min(lowest, result[k].all_corners_rms_px);
    *lowest_rms = lowest;
    size_t chosen = end;
    for (size_t k = 0; k < end; ++k) {
      if (!passes(k) ||
          !(result[k].all_corners_rms_px <= lowest * (1 + options.model_rms_margin)))
        continue;
      if (chosen == end || muchSurer(result[k].uncertainty, result[chosen].uncertainty,
                                     options.model_uncertainty_margin))
        chosen = k;
    }
    return chosen;
  };
  double lowest_listed = 0, lowest_all = 0;
  const size_t chosen = best(listed, &lowest_listed);
  const size_t reference = best(models.size(), &lowest_all);
  ModelChoice choice;
  if (chosen < listed) {
    const std::string with = " with " + distortionModelName(models[chosen]);
    for (size_t j = 0; j < chosen; ++j) {
      if (!passes(j)) continue;
      const bool eligible =
          result[j].all_corners_rms_px <= lowest_listed * (1 + options.model_rms_margin);
      reasons[j] = {
          eligible
              ? fmt("the gate passed it and it explains the corners as well (%.4f px RMS over all "
                    "of them, outliers included, against %.4f px",
                    result[j].all_corners_rms_px, result[chosen].all_corners_rms_px) +
                    with +
                    fmt("), but the views pin it down less where no board was seen: projection "
                        "uncertainty %.3f px RMS over the image and %.3f px in its worst cell "
                        "against %.3f px",
                        sureness(j), worstSureness(j), sureness(chosen)) +
                    fmt(" and %.3f px", worstSureness(chosen)) + with +
                    ": it does not fit this lens there"
              : fmt("the gate passed it, but it explains the corners worse: %.4f px RMS over all "
                    "of them (outliers included) against %.4f px",
                    result[j].all_corners_rms_px, result[chosen].all_corners_rms_px) +
                    with + ": it does not fit this lens"};
    }
    choice.passed = true;
    if (reference != chosen && reference < models.size()) {
      // A model not listed fits best: the chosen one is written only where it projects as that
      // one does over the whole image.
      const ModelDifference d =
          modelDifference(result[chosen].intrinsics, result[reference].intrinsics,
                          gate.max_model_difference_px, result[chosen].uncertainty.grid);
      if (!(d.worst_px <= gate.max_model_difference_px)) {
        choice.passed = false;
        reasons[chosen] = {
            distortionModelName(models[reference]) +
            fmt(", which these views fit best (not listed), projects %.2f px RMS and up to %.1f "
                "px away from it over the image (limit %.2f px); ",
                d.rms_px, d.worst_px, gate.max_model_difference_px) +
            fmt("it is within that limit only within %.0f px of the image centre (%.0f %% of "
                "the image): ",
                d.valid_radius_px, 100 * d.valid_fraction) +
            distortionModelName(models[chosen]) +
            " does not fit this lens there; list " + distortionModelName(models[reference]) +
            " in fallback_models if the file's consumers read it"};
      }
    }
  } else if (reference < models.size()) {
    // None listed passes: say which model would, and how far the first listed one is from it.
    for (size_t k = 0; k < listed; ++k) {
      if (!fitted[k]) continue;
      const ModelDifference d =
          modelDifference(result[k].intrinsics, result[reference].intrinsics,
                          gate.max_model_difference_px, result[k].uncertainty.grid);
      reasons[k].push_back(
          distortionModelName(models[reference]) + " (not listed) fits these views" +
          fmt(": this fit projects %.2f px RMS and up to %.1f px away from it", d.rms_px,
              d.worst_px) +
          fmt(", within %.2f px only within %.0f px of the image centre",
              gate.max_model_difference_px, d.valid_radius_px));
    }
  }
  // The refusals: the models before the chosen one, and the chosen one itself when it is refused
  // for its difference from the model that fits best; every listed model when none passed.
  const size_t shown = chosen < listed ? chosen + (choice.passed ? 0 : 1) : listed;
  for (size_t k = 0; k < shown; ++k) choice.refused.push_back({models[k], reasons[k]});
  choice.result = std::move(result[choice.passed || chosen < listed ? chosen : 0]);
  if (choice.passed) {
    for (const ModelChoice::Refusal& f : choice.refused) {
      choice.result.refused_models += (choice.result.refused_models.empty() ? "" : " | ") +
                                      distortionModelName(f.model) + ": ";
      for (size_t j = 0; j < f.reasons.size(); ++j)
        choice.result.refused_models += (j ? "; " : "") + f.reasons[j];
    }
  }
  return choice;
}

}  // namespace camera
}  // namespace autocal
