#include "autocal/camera/view_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"

namespace autocal {
namespace camera {

namespace {
const char* const kRepeatedFrame = "the same corners as an earlier view (a repeated frame)";

double angleAt(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c) {
  const cv::Point2d ab = a - b, cb = c - b;
  const double cosine = ab.dot(cb) / (cv::norm(ab) * cv::norm(cb));
  return std::acos(std::clamp(cosine, -1.0, 1.0));
}
}  // namespace

ViewParams computeViewParams(const std::vector<cv::Point2f>& corners, const cv::Size& image_size,
                             const BoardSpec& board, const ViewSelectionOptions& options) {
  const int w = board.inner_corners.width, h = board.inner_corners.height;
  const cv::Point2d up_left = corners[0], up_right = corners[w - 1],
                    down_right = corners[h * w - 1], down_left = corners[(h - 1) * w];
  // Same definitions as ROS camera_calibration's get_parameters().
  const cv::Point2d a = up_right - up_left, b = down_right - up_right, c = down_left - down_right;
  const double area = std::abs((a.x * b.y - a.y * b.x) + (b.x * c.y - b.y * c.x)) / 2.0;
  const double border = std::sqrt(area);
  cv::Point2d mean(0, 0);
  for (const auto& p : corners) mean += cv::Point2d(p);
  mean *= 1.0 / static_cast<double>(corners.size());
  ViewParams v;
  v.x = std::clamp((mean.x - border / 2) / (image_size.width - border), 0.0, 1.0);
  v.y = std::clamp((mean.y - border / 2) / (image_size.height - border), 0.0, 1.0);
  v.size = std::sqrt(area / (static_cast<double>(image_size.width) * image_size.height));
  v.skew = std::min(1.0, 2.0 * std::abs(M_PI / 2 - angleAt(up_left, up_right, down_right)));

  // Distance and tilt from a pose fitted with nominal intrinsics: rough, but the ordering of
  // views by distance and tilt does not need the true focal length.
  const double f = options.nominal_focal_width_ratio * image_size.width;
  const cv::Matx33d k(f, 0, image_size.width / 2.0, 0, f, image_size.height / 2.0, 0, 0, 1);
  cv::Vec3d rvec, tvec;
  bool posed = false;
  try {
    posed = cv::solvePnP(board.points(), corners, k, cv::noArray(), rvec, tvec, false,
                         cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    // A degenerate view (corners collinear, or a board seen edge-on): no distance or tilt.
    posed = false;
  }
  if (posed) {
    cv::Matx33d r;
    cv::Rodrigues(rvec, r);
    v.distance_m = cv::norm(tvec);
    v.tilt_rad = std::acos(std::min(1.0, std::abs(r(2, 2))));
    v.distance = std::clamp(v.distance_m / options.max_distance_m, 0.0, 1.0);
    v.tilt = std::clamp(v.tilt_rad / (M_PI / 2), 0.0, 1.0);
  }
  return v;
}

std::string Coverage::summary() const {
  static const char* names[6] = {"X", "Y", "size", "skew", "dist", "tilt"};
  std::string s;
  char buf[64];
  for (int i = 0; i < 6; ++i) {
    std::snprintf(buf, sizeof buf, "%s%s %.2f", i ? " " : "", names[i], progress[i]);
    s += buf;
  }
  std::snprintf(buf, sizeof buf, ", %d views%s", views, sufficient ? " (sufficient)" : "");
  return s + buf;
}

bool FrameResult::any_kept() const {
  return std::any_of(decisions.begin(), decisions.end(),
                     [](const ViewDecision& d) { return d.kept; });
}

ViewCollector::ViewCollector(const BoardSpec& board, const ChessboardDetectorOptions& detector,
                             const ViewSelectionOptions& selection)
    : board_(board), detector_(detector), selection_(selection) {}

FrameResult ViewCollector::addFrame(const cv::Mat& image, const std::string& source) {
  return add(detect(image, source), source);
}

DetectedFrame ViewCollector::detect(const cv::Mat& image, const std::string& source) const {
  if (image.empty()) throw InputError(source + ": empty or undecodable image");
  DetectedFrame frame;
  frame.image_size = image.size();
  const cv::Mat gray = toGray(image);
  for (BoardDetection& board : detectChessboards(gray, board_, detector_)) {
    DetectedBoard b;
    b.edge_width_px = edgeWidthPx(gray, board.corners);
    b.sharp = usableAndSharp(board.corners, b.edge_width_px, frame.image_size);
    b.corners = board.corners;
    // The slow sub-pixel refinement only for boards that may be calibrated on.
    if (b.sharp) {
      refineCorners(gray, board_, board, detector_);
      b.refined = std::move(board.corners);
      if (detector_.refine_through_lens)
        b.patch = boardPatch(gray, b.refined, detector_.refine_max_half_window_px + 8);
    }
    frame.boards.push_back(std::move(b));
  }
  return frame;
}

FrameResult ViewCollector::add(DetectedFrame frame, const std::string& source) {
  if (image_size_.area() == 0) image_size_ = frame.image_size;
  if (frame.image_size != image_size_) {
    throw InputError(source + ": image is " + std::to_string(frame.image_size.width) + "x" +
                     std::to_string(frame.image_size.height) + " but earlier ones are " +
                     std::to_string(image_size_.width) + "x" + std::to_string(image_size_.height) +
                     " (one calibration needs one image size)");
  }
  const int frame_index = frames_++;
  FrameResult result;
  result.boards_found = static_cast<int>(frame.boards.size());
  for (DetectedBoard& board : frame.boards) {
    ViewDecision d = judge(board.corners, board.edge_width_px);
    d.sharp = board.sharp;
    if (d.kept || (board.sharp && selection_.keep_sharp_views)) {
      d.corners = board.refined;
      if (repeatsSharpView(board.refined)) {
        d.kept = d.sharp = false;
        d.reason = kRepeatedFrame;
        result.decisions.push_back(d);
        continue;
      }
      CalibrationView v;
      v.corners = std::move(board.refined);
      v.params = d.params;
      v.edge_width_px = d.edge_width_px;
      v.source = source;
      v.frame_index = frame_index;
      v.patch = std::move(board.patch);
      if (d.kept) views_.push_back(v);
      if (selection_.keep_sharp_views) sharp_views_.push_back(std::move(v));
    }
    result.decisions.push_back(d);
  }
  return result;
}

ViewDecision ViewCollector::addView(const std::vector<cv::Point2f>& corners,
                                    const cv::Size& image_size, double edge_width_px,
                                    const std::string& source) {
  if (image_size_.area() == 0) image_size_ = image_size;
  ViewDecision d = judge(corners, edge_width_px);
  d.sharp = usableAndSharp(corners, edge_width_px, image_size_);
  if ((d.kept || d.sharp) && repeatsSharpView(corners)) {
    d.kept = d.sharp = false;
    d.reason = kRepeatedFrame;
  }
  if (d.kept || (selection_.keep_sharp_views && d.sharp)) {
    CalibrationView v;
    v.corners = corners;
    v.params = d.params;
    v.edge_width_px = edge_width_px;
    v.source = source;
    v.frame_index = frames_;
    if (d.kept) views_.push_back(v);
    if (selection_.keep_sharp_views) sharp_views_.push_back(std::move(v));
  }
  ++frames_;
  return d;
}

bool ViewCollector::usableAndSharp(const std::vector<cv::Point2f>& corners, double edge_width_px,
                                   const cv::Size& image_size) const {
  if (static_cast<int>(corners.size()) != board_.cornerCount()) return false;
  for (const auto& p : corners) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
  }
  return edge_width_px <= selection_.max_edge_width_px && nearEdge(corners, image_size).empty();
}

bool ViewCollector::repeatsSharpView(const std::vector<cv::Point2f>& corners) const {
  for (const CalibrationView& v : selection_.keep_sharp_views ? sharp_views_ : views_) {
    if (v.corners.size() != corners.size()) continue;
    bool same = true;
    for (size_t i = 0; same && i < corners.size(); ++i)
      same = std::abs(v.corners[i].x - corners[i].x) < 1e-3f &&
             std::abs(v.corners[i].y - corners[i].y) < 1e-3f;
    if (same) return true;
  }
  return false;
}

std::string ViewCollector::nearEdge(const std::vector<cv::Point2f>& corners,
                                    const cv::Size& image_size) const {
  if (!(selection_.min_edge_distance_spacings > 0) || image_size.area() == 0) return "";
  const int cols = board_.inner_corners.width, rows = board_.inner_corners.height;
  if (static_cast<int>(corners.size()) != cols * rows) return "";
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const cv::Point2f& p = corners[static_cast<size_t>(r * cols + c)];
      double spacing = std::numeric_limits<double>::infinity();
      for (const auto& [dr, dc] : {std::pair{0, 1}, {0, -1}, {1, 0}, {-1, 0}}) {
        const int rr = r + dr, cc = c + dc;
        if (rr < 0 || rr >= rows || cc < 0 || cc >= cols) continue;
        spacing = std::min(
            spacing,
            static_cast<double>(cv::norm(p - corners[static_cast<size_t>(rr * cols + cc)])));
      }
      const double edge = std::min({static_cast<double>(p.x), static_cast<double>(p.y),
                                    image_size.width - 1.0 - p.x, image_size.height - 1.0 - p.y});
      if (edge < selection_.min_edge_distance_spacings * spacing) {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "cut by the image's edge: a corner at (%.0f, %.0f) is %.1f px from it, "
                      "less than %.1f corner spacings (%.1f px)",
                      p.x, p.y, edge, selection_.min_edge_distance_spacings, spacing);
        return buf;
      }
    }
  }
  return "";
}

ViewDecision ViewCollector::judge(const std::vector<cv::Point2f>& corners, double edge_width_px) {
  ViewDecision d;
  d.corners = corners;
  d.edge_width_px = edge_width_px;
  char buf[160];
  if (static_cast<int>(corners.size()) != board_.cornerCount()) {
    d.reason = "wrong corner count " + std::to_string(corners.size());
    return d;
  }
  for (const auto& p : corners) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
      d.reason = "corner is NaN or infinite";
      return d;
    }
  }
  d.params = computeViewParams(corners, image_size_, board_, selection_);
  if (!(edge_width_px <= selection_.max_edge_width_px)) {
    std::snprintf(buf, sizeof buf, "blurred: edge width %.1f px > %.1f px", edge_width_px,
                  selection_.max_edge_width_px);
    d.reason = buf;
    return d;
  }
  d.reason = nearEdge(corners, image_size_);
  if (!d.reason.empty()) return d;
  if (static_cast<int>(views_.size()) >= selection_.max_views) {
    d.reason = "enough views already (" + std::to_string(views_.size()) + ")";
    return d;
  }
  double nearest = std::numeric_limits<double>::infinity();
  size_t nearest_index = 0;
  const auto p = d.params.asArray();
  for (size_t i = 0; i < views_.size(); ++i) {
    const auto q = views_[i].params.asArray();
    double l1 = 0;
    for (size_t k = 0; k < p.size(); ++k) l1 += std::abs(p[k] - q[k]);
    if (l1 < nearest) {
      nearest = l1;
      nearest_index = i;
    }
  }
  if (nearest < selection_.min_novelty) {
    std::snprintf(buf, sizeof buf, "too similar to kept view %zu (%s): novelty %.3f < %.3f",
                  nearest_index, views_[nearest_index].source.c_str(), nearest,
                  selection_.min_novelty);
    d.reason = buf;
    return d;
  }
  d.kept = true;
  d.reason = "kept";
  return d;
}

Coverage ViewCollector::coverage() const {
  Coverage c;
  c.views = static_cast<int>(views_.size());
  if (views_.empty()) return c;
  std::array<double, 6> lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  for (const auto& v : views_) {
    const auto a = v.params.asArray();
    for (size_t k = 0; k < a.size(); ++k) {
      lo[k] = std::min(lo[k], a[k]);
      hi[k] = std::max(hi[k], a[k]);
    }
  }
  bool all = true;
  for (size_t k = 0; k < 6; ++k) {
    c.spread[k] = hi[k] - lo[k];
    const double goal = selection_.goal_spread[k];
    c.progress[k] = goal > 0 ? std::min(1.0, c.spread[k] / goal) : 1.0;
    all = all && c.progress[k] >= 1.0;
  }
  c.sufficient = (all && c.views >= selection_.min_views) || c.views >= selection_.max_views;
  return c;
}

}  // namespace camera
}  // namespace autocal
