// Duckietown's board-on-the-floor extrinsics from one image (see floor_board.h).
#include "autocal/extrinsics/floor_board.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/camera/chessboard.h"
#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace extrinsics {

namespace {

std::string deg(double rad) { return formatNumber(rad * 180 / M_PI, 3) + " deg"; }
std::string cm(double m) { return formatNumber(m * 100, 3) + " cm"; }

/// The six mount numbers as a vector (for the covariance).
Eigen::Matrix<double, 6, 1> asVector(const CameraMount& m) {
  Eigen::Matrix<double, 6, 1> v;
  v << m.height_m, m.pitch_rad, m.roll_rad, m.yaw_rad, m.x_m, m.y_m;
  return v;
}

/// The mount of the camera whose rectified frame sees robot-frame points p at R_pnp·p + t.
CameraMount mountOfPose(const cv::Vec3d& rvec, const cv::Vec3d& tvec, const RectifiedCamera& cam) {
  cv::Matx33d r_cv;
  cv::Rodrigues(rvec, r_cv);
  Eigen::Matrix3d r_pnp;
  cv::cv2eigen(r_cv, r_pnp);
  // p_rect = Rrect·p_camera: the camera's own frame is Rrectᵀ·(R_pnp·p + t).
  const Eigen::Matrix3d robot_to_camera = cam.R.transpose() * r_pnp;
  const Eigen::Vector3d t_camera = cam.R.transpose() * Eigen::Vector3d(tvec[0], tvec[1], tvec[2]);
  // Through the homography: the decomposition's angle conventions, in one place.
  RectifiedCamera unit;
  Eigen::Matrix3d plane;
  plane.col(0) = robot_to_camera.col(0);
  plane.col(1) = robot_to_camera.col(1);
  plane.col(2) = t_camera;
  return mountFromHomography(plane.inverse(), unit);
}

void checkLimits(const CameraMount& m, const MountLimits& l) {
  std::string why;
  if (!(m.height_m >= l.min_height_m && m.height_m <= l.max_height_m))
    why = "height " + cm(m.height_m) + " (" + cm(l.min_height_m) + ".." + cm(l.max_height_m) + ")";
  else if (!(m.pitch_rad >= l.min_pitch_rad && m.pitch_rad <= l.max_pitch_rad))
    why = "pitch " + deg(m.pitch_rad) + " (" + deg(l.min_pitch_rad) + ".." + deg(l.max_pitch_rad) +
          ")";
  else if (!(std::abs(m.roll_rad) <= l.max_abs_roll_rad))
    why = "roll " + deg(m.roll_rad) + " (at most " + deg(l.max_abs_roll_rad) + ")";
  else if (!(std::abs(m.yaw_rad) <= l.max_abs_yaw_rad))
    why = "yaw " + deg(m.yaw_rad) + " (at most " + deg(l.max_abs_yaw_rad) + ")";
  else if (!(m.x_m >= l.min_x_m && m.x_m <= l.max_x_m))
    why = "forward offset " + cm(m.x_m) + " (" + cm(l.min_x_m) + ".." + cm(l.max_x_m) + ")";
  else if (!(std::abs(m.y_m) <= l.max_abs_y_m))
    why = "lateral offset " + cm(m.y_m) + " (at most " + cm(l.max_abs_y_m) + ")";
  if (!why.empty()) {
    throw CalibrationError("the board gives a camera pose no Duckiebot can have: " + why +
                           "; is the board where offset_x/offset_y say, and the image this "
                           "camera's?");
  }
}

}  // namespace

void FloorBoard::validate() const {
  if (cols < 2 || rows < 2 || cols == rows)
    throw ConfigError(
        "board: needs at least 2x2 inner corners, and as many columns as rows is "
        "ambiguous on the floor (got " +
        std::to_string(cols) + "x" + std::to_string(rows) + ")");
  if (!(square_m > 0 && square_m < 1)) throw ConfigError("square: must be within (0, 1) [m]");
  if (!std::isfinite(offset_x_m) || !(offset_x_m > 0))
    throw ConfigError("offset_x: must be > 0 [m] (the board lies ahead of the axle)");
  if (!std::isfinite(offset_y_m)) throw ConfigError("offset_y: must be a number [m]");
}

std::vector<Eigen::Vector2d> FloorBoard::cornersOnFloor() const {
  std::vector<Eigen::Vector2d> pts;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c)
      pts.emplace_back(offset_x_m + r * square_m, -offset_y_m + c * square_m);
  }
  return pts;
}

cv::Mat rectifyImage(const cv::Mat& raw, const CameraInfoRectification& camera) {
  const CameraIntrinsics& in = camera.intrinsics;
  if (raw.cols != in.width || raw.rows != in.height) {
    throw InputError("the image is " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) +
                     ", the camera_info's " + std::to_string(in.width) + "x" +
                     std::to_string(in.height));
  }
  cv::Mat P, R;
  cv::eigen2cv(camera.rectified.P, P);
  cv::eigen2cv(camera.rectified.R, R);
  cv::Mat map1, map2;
  const cv::Mat K(in.cameraMatrix());
  const cv::Mat D(in.distortion_coefficients);
  if (in.distortion_model == DistortionModel::kEquidistant) {
    cv::fisheye::initUndistortRectifyMap(K, D, R, P, in.imageSize(), CV_32FC1, map1, map2);
  } else {
    cv::initUndistortRectifyMap(K, D, R, P, in.imageSize(), CV_32FC1, map1, map2);
  }
  cv::Mat out;
  cv::remap(raw, out, map1, map2, cv::INTER_LINEAR);
  return out;
}

void drawFloorGrid(cv::Mat& rectified_bgr, const Eigen::Matrix3d& homography,
                   const FloorGrid& grid) {
  if (rectified_bgr.type() != CV_8UC3) throw InputError("drawFloorGrid: the image must be BGR");
  if (!(grid.step_m > 0 && grid.x_far_m > grid.x_near_m && grid.y_half_m > 0))
    throw ConfigError("drawFloorGrid: the grid must have a positive step and extent");
  // Each line as short segments (a line on the floor is a line in the rectified image, but its
  // far end may lie beyond the horizon of a steep camera: points behind it are left out).
  // A floor point in front of the camera maps to a pixel with the sign of w that a pixel seeing
  // the floor has (the bottom row's middle); points behind the camera have the other.
  const Eigen::Matrix3d to_pixel = homography.inverse();
  const double w_floor = homography.row(2).dot(
      Eigen::Vector3d(0.5 * rectified_bgr.cols, rectified_bgr.rows - 1.0, 1.0));
  const double front = w_floor > 0 ? 1.0 : -1.0;
  const auto line = [&](Eigen::Vector2d a, Eigen::Vector2d b, const cv::Scalar& colour) {
    const int pieces = 24;
    for (int i = 0; i < pieces; ++i) {
      const Eigen::Vector2d p = a + (b - a) * i / pieces, q = a + (b - a) * (i + 1) / pieces;
      const Eigen::Vector3d hp = front * (to_pixel * Eigen::Vector3d(p.x(), p.y(), 1));
      const Eigen::Vector3d hq = front * (to_pixel * Eigen::Vector3d(q.x(), q.y(), 1));
      if (hp.z() <= 0 || hq.z() <= 0) continue;
      cv::line(rectified_bgr, cv::Point2d(hp.x() / hp.z(), hp.y() / hp.z()),
               cv::Point2d(hq.x() / hq.z(), hq.y() / hq.z()), colour, 1, cv::LINE_AA);
    }
  };
  const cv::Scalar green(60, 200, 60), yellow(0, 220, 255);
  const int nx = static_cast<int>(std::floor((grid.x_far_m - grid.x_near_m) / grid.step_m + 1e-9));
  const int ny = static_cast<int>(std::floor(grid.y_half_m / grid.step_m + 1e-9));
  for (int i = 0; i <= nx; ++i) {
    const double x = grid.x_near_m + i * grid.step_m;
    line({x, -grid.y_half_m}, {x, grid.y_half_m}, green);
  }
  for (int j = -ny; j <= ny; ++j) {
    const double y = j * grid.step_m;
    line({grid.x_near_m, y}, {grid.x_far_m, y}, j == 0 ? yellow : green);
  }
}

FloorBoardResult calibrateFromFloorBoard(const cv::Mat& raw_image,
                                         const CameraInfoRectification& camera,
                                         const FloorBoardOptions& options) {
  options.board.validate();
  const FloorBoard& board = options.board;
  const cv::Mat gray = camera::toGray(rectifyImage(raw_image, camera));

  camera::BoardSpec spec;
  spec.inner_corners = cv::Size(board.cols, board.rows);
  spec.square_size_m = board.square_m;
  camera::ChessboardDetectorOptions det;
  det.max_boards = 1;
  det.adaptive_threshold = true;
  // One board, large in the image: no need for the sweep's shortcuts.
  det.half_resolution_precheck = false;
  det.fast_check = false;
  std::vector<camera::BoardDetection> found = camera::detectChessboards(gray, spec, det);
  if (found.empty()) {
    // OpenCV's sector-based detector finds boards the quad search misses (a margin cut by the
    // image's edge, strong perspective).
    camera::BoardDetection d;
    if (cv::findChessboardCornersSB(gray, spec.inner_corners, d.corners,
                                    cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE))
      found.push_back(d);
  }
  if (found.empty()) {
    throw CalibrationError("the " + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                           " board was not found in the rectified image: is all of it in view, "
                           "and the board's size right?");
  }
  camera::refineCorners(gray, spec, found.front(), det);
  std::vector<cv::Point2f> corners = found.front().corners;

  // OpenCV gives rows of `cols` corners from either end of the board. Order them as
  // cornersOnFloor: the first row the nearest (lowest in the image), each row from the right.
  auto rowV = [&](int r) {
    double v = 0;
    for (int c = 0; c < board.cols; ++c) v += corners[r * board.cols + c].y;
    return v;
  };
  if (rowV(0) < rowV(board.rows - 1)) {
    for (int r = 0; r < board.rows / 2; ++r) {
      std::swap_ranges(corners.begin() + r * board.cols, corners.begin() + (r + 1) * board.cols,
                       corners.begin() + (board.rows - 1 - r) * board.cols);
    }
  }
  double along = 0;  // image u from the first column to the last
  for (int r = 0; r < board.rows; ++r)
    along += corners[r * board.cols + board.cols - 1].x - corners[r * board.cols].x;
  if (along > 0) {
    for (int r = 0; r < board.rows; ++r)
      std::reverse(corners.begin() + r * board.cols, corners.begin() + (r + 1) * board.cols);
  }

  // The camera's pose from the corners: the rectified image has no distortion and camera matrix P.
  const std::vector<Eigen::Vector2d> floor = board.cornersOnFloor();
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t i = 0; i < floor.size(); ++i) {
    object.emplace_back(floor[i].x(), floor[i].y(), 0.0);
    image.emplace_back(corners[i].x, corners[i].y);
  }
  cv::Mat P;
  cv::eigen2cv(camera.rectified.P, P);
  cv::Vec3d rvec, tvec;
  if (!cv::solvePnP(object, image, P, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE) ||
      !cv::solvePnP(object, image, P, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE)) {
    throw CalibrationError("the board's corners give no camera pose");
  }

  FloorBoardResult out;
  out.mount = mountOfPose(rvec, tvec, camera.rectified);
  out.homography = homographyFromMount(out.mount, camera.rectified);
  double sum_m = 0, sum_px = 0;
  std::vector<cv::Point2d> projected;
  cv::Mat jacobian;
  cv::projectPoints(object, rvec, tvec, P, cv::noArray(), projected, jacobian);
  for (size_t i = 0; i < floor.size(); ++i) {
    const Eigen::Vector2d px(image[i].x, image[i].y);
    out.corners_px.push_back(px);
    const double e = (pixelToGround(out.homography, px) - floor[i]).norm();
    sum_m += e * e;
    out.board_max_m = std::max(out.board_max_m, e);
    const double dx = projected[i].x - image[i].x, dy = projected[i].y - image[i].y;
    sum_px += dx * dx + dy * dy;
  }
  const double n = static_cast<double>(floor.size());
  out.board_rms_m = std::sqrt(sum_m / n);
  out.reprojection_rms_px = std::sqrt(sum_px / n);

  // The mount's uncertainty: the pose's covariance σ²(JᵀJ)⁻¹ (σ the corners' scatter per
  // coordinate, 2n − 6 degrees of freedom) carried to the six numbers by finite differences.
  const double sigma_px = std::sqrt(sum_px / std::max(1.0, 2 * n - 6));
  Eigen::MatrixXd J;
  cv::cv2eigen(jacobian.colRange(0, 6), J);
  const Eigen::Matrix<double, 6, 6> cov = sigma_px * sigma_px * (J.transpose() * J).inverse();
  Eigen::Matrix<double, 6, 6> D;  // d mount / d (rvec, tvec)
  const Eigen::Matrix<double, 6, 1> m0 = asVector(out.mount);
  for (int k = 0; k < 6; ++k) {
    cv::Vec3d r = rvec, t = tvec;
    const double h = 1e-6;
    (k < 3 ? r[k] : t[k - 3]) += h;
    D.col(k) = (asVector(mountOfPose(r, t, camera.rectified)) - m0) / h;
  }
  const Eigen::Matrix<double, 6, 1> sd = (D * cov * D.transpose()).diagonal().cwiseSqrt();
  out.mount_sigma = {sd[0], sd[1], sd[2], sd[3], sd[4], sd[5]};

  if (!(out.board_rms_m <= options.max_board_rms_m)) {
    throw CalibrationError("the board's corners lie " + cm(out.board_rms_m) +
                           " RMS off the fitted pose on the floor (at most " +
                           cm(options.max_board_rms_m) +
                           "): is the board flat, and are its size and square right?");
  }
  checkLimits(out.mount, options.limits);
  return out;
}

}  // namespace extrinsics
}  // namespace autocal
