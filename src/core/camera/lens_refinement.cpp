#include "autocal/camera/lens_refinement.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace autocal {
namespace camera {

namespace {

// A corner already refined moves by hundredths of a pixel; one that moves farther is left alone.
constexpr double kMaxMovePx = 1.0;

bool isFisheye(const CameraIntrinsics& lens) {
  return lens.distortion_model == DistortionModel::kEquidistant;
}

// Normalised pinhole coordinates (x/z, y/z) to pixels through the lens.
std::vector<cv::Point2f> distort(const std::vector<cv::Point3f>& rays,
                                 const CameraIntrinsics& lens) {
  std::vector<cv::Point2f> out;
  if (rays.empty()) return out;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (isFisheye(lens)) {
    cv::fisheye::projectPoints(rays, out, zero, zero, cv::Mat(lens.cameraMatrix()),
                               cv::Mat(lens.distortion_coefficients));
  } else {
    cv::projectPoints(rays, zero, zero, cv::Mat(lens.cameraMatrix()),
                      cv::Mat(lens.distortion_coefficients), out);
  }
  return out;
}

// Pixels to the pinhole image with the lens's own camera matrix.
std::vector<cv::Point2f> undistort(const std::vector<cv::Point2f>& pixels,
                                   const CameraIntrinsics& lens) {
  std::vector<cv::Point2f> out;
  const cv::Mat k(lens.cameraMatrix());
  const cv::TermCriteria exact(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-12);
  if (isFisheye(lens)) {
    cv::fisheye::undistortPoints(pixels, out, k, cv::Mat(lens.distortion_coefficients),
                                 cv::noArray(), k, exact);
  } else {
    cv::undistortPoints(pixels, out, k, cv::Mat(lens.distortion_coefficients), cv::noArray(), k,
                        exact);
  }
  return out;
}

}  // namespace

BoardPatch boardPatch(const cv::Mat& gray, const std::vector<cv::Point2f>& corners,
                      int margin_px) {
  BoardPatch patch;
  if (gray.empty() || corners.empty()) return patch;
  const cv::Rect box = cv::boundingRect(corners);
  const cv::Rect grown(box.x - margin_px, box.y - margin_px, box.width + 2 * margin_px,
                       box.height + 2 * margin_px);
  const cv::Rect roi = grown & cv::Rect(0, 0, gray.cols, gray.rows);
  if (roi.area() == 0) return patch;
  patch.gray = gray(roi).clone();
  patch.origin = roi.tl();
  return patch;
}

std::vector<cv::Point2f> refineThroughLens(const BoardPatch& patch, const BoardSpec& spec,
                                           const std::vector<cv::Point2f>& corners,
                                           const CameraIntrinsics& lens,
                                           const ChessboardDetectorOptions& options) {
  if (patch.gray.empty() || corners.empty()) return corners;
  const std::vector<cv::Point2f> pinhole = undistort(corners, lens);
  const int half = std::clamp(
      static_cast<int>(std::ceil(minCornerSpacingPx(corners, spec) * options.refine_window_ratio)),
      options.refine_min_half_window_px, options.refine_max_half_window_px);
  // Each corner's neighbourhood as a pinhole camera looking along the corner's ray would see it
  // (focal length fx: about the lens's own scale there), one pixel per grid point, with a border
  // for cornerSubPix's gradients and the corner's travel.
  const int reach = half + 4, side = 2 * reach + 1;
  const double f = lens.fx;
  std::vector<cv::Matx33d> turn;  // virtual camera -> camera
  std::vector<cv::Point3f> rays;
  rays.reserve(corners.size() * static_cast<size_t>(side * side));
  for (const cv::Point2f& p : pinhole) {
    const cv::Vec3d z = cv::normalize(cv::Vec3d((p.x - lens.cx) / lens.fx,
                                                (p.y - lens.cy) / lens.fy, 1.0));
    const cv::Vec3d x = cv::normalize(cv::Vec3d(1, 0, 0) - z * z[0]);
    const cv::Vec3d y = z.cross(x);
    turn.emplace_back(x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]);
    for (int v = -reach; v <= reach; ++v) {
      for (int u = -reach; u <= reach; ++u) {
        const cv::Vec3d r = turn.back() * cv::Vec3d(u / f, v / f, 1.0);
        rays.emplace_back(static_cast<float>(r[0] / r[2]), static_cast<float>(r[1] / r[2]), 1.0f);
      }
    }
  }
  const std::vector<cv::Point2f> source = distort(rays, lens);
  std::vector<cv::Point2f> out = corners;
  const cv::Rect inside(0, 0, patch.gray.cols - 1, patch.gray.rows - 1);
  const cv::TermCriteria stop(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-4);
  for (size_t i = 0; i < corners.size(); ++i) {
    if (!std::isfinite(pinhole[i].x) || !std::isfinite(pinhole[i].y)) continue;
    cv::Mat map_x(side, side, CV_32F), map_y(side, side, CV_32F);
    bool covered = true;
    for (int y = 0; y < side && covered; ++y) {
      for (int x = 0; x < side; ++x) {
        const cv::Point2f s =
            source[i * static_cast<size_t>(side * side) + static_cast<size_t>(y * side + x)] -
            cv::Point2f(patch.origin);
        if (!inside.contains(cv::Point(cvFloor(s.x), cvFloor(s.y)))) {
          covered = false;
          break;
        }
        map_x.at<float>(y, x) = s.x;
        map_y.at<float>(y, x) = s.y;
      }
    }
    if (!covered) continue;
    cv::Mat local;
    cv::remap(patch.gray, local, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
    const cv::Point2f centre(static_cast<float>(reach), static_cast<float>(reach));
    std::vector<cv::Point2f> refined{centre};
    cv::cornerSubPix(local, refined, cv::Size(half, half), cv::Size(-1, -1), stop);
    const cv::Point2f q = refined[0] - centre;
    if (!std::isfinite(q.x) || !std::isfinite(q.y)) continue;
    const cv::Vec3d r = turn[i] * cv::Vec3d(q.x / f, q.y / f, 1.0);
    if (!(r[2] > 0)) continue;
    const cv::Point2f back = distort(
        {cv::Point3f(static_cast<float>(r[0] / r[2]), static_cast<float>(r[1] / r[2]), 1.0f)},
        lens)
                                 .front();
    // A lens that folds here (a model extrapolated past its views) maps the corner elsewhere.
    if (std::isfinite(back.x) && std::isfinite(back.y) &&
        cv::norm(back - corners[i]) <= kMaxMovePx)
      out[i] = back;
  }
  return out;
}

}  // namespace camera
}  // namespace autocal
