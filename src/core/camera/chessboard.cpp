#include "autocal/camera/chessboard.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace camera {

std::vector<cv::Point3f> BoardSpec::points() const {
  std::vector<cv::Point3f> points;
  for (int r = 0; r < inner_corners.height; ++r) {
    for (int c = 0; c < inner_corners.width; ++c) {
      points.emplace_back(static_cast<float>(c * square_size_m),
                          static_cast<float>(r * square_size_m), 0.0f);
    }
  }
  return points;
}

std::string BoardSpec::describe() const {
  return std::to_string(inner_corners.width) + "x" + std::to_string(inner_corners.height) + ", " +
         formatNumber(square_size_m) + " m squares";
}

void BoardSpec::validate() const {
  if (inner_corners.width < 3 || inner_corners.height < 3) {
    throw ConfigError("board.inner_corners: needs at least 3x3 inner corners, got " +
                      std::to_string(inner_corners.width) + "x" +
                      std::to_string(inner_corners.height));
  }
  if (inner_corners.width == inner_corners.height) {
    throw ConfigError(
        "board.inner_corners: a square board's orientation is ambiguous; use one with different "
        "numbers of inner corners per row and column");
  }
  if (!(square_size_m > 0) || !std::isfinite(square_size_m)) {
    throw ConfigError("board.square_size_m: must be > 0, got " + formatNumber(square_size_m));
  }
}

cv::Mat toGray(const cv::Mat& image) {
  if (image.empty()) throw InputError("empty image");
  if (image.depth() != CV_8U) throw InputError("image is not 8-bit");
  cv::Mat gray;
  switch (image.channels()) {
    case 1:
      return image;
    case 3:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      return gray;
    case 4:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      return gray;
    default:
      throw InputError("image has " + std::to_string(image.channels()) + " channels");
  }
}

double minCornerSpacingPx(const std::vector<cv::Point2f>& corners, const BoardSpec& board) {
  const cv::Size& pattern_size = board.inner_corners;
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < pattern_size.height; ++r) {
    for (int c = 0; c < pattern_size.width; ++c) {
      const cv::Point2f& p = corners[r * pattern_size.width + c];
      if (c + 1 < pattern_size.width)
        best = std::min(best, cv::norm(p - corners[r * pattern_size.width + c + 1]));
      if (r + 1 < pattern_size.height)
        best = std::min(best, cv::norm(p - corners[(r + 1) * pattern_size.width + c]));
    }
  }
  return best;
}

namespace {

// The board's outline grown by about one square, so painting it removes the whole board
// (outer squares included) before searching for the next one.
std::vector<cv::Point> grownHull(const std::vector<cv::Point2f>& corners, const cv::Size& pattern) {
  const int w = pattern.width, h = pattern.height;
  const cv::Point2f tl = corners[0], tr = corners[w - 1], bl = corners[(h - 1) * w],
                    br = corners[h * w - 1];
  const cv::Point2f centre = (tl + tr + bl + br) * 0.25f;
  // The outer corners lie (w-1)/2 and (h-1)/2 squares from the centre; scaling them by this
  // factor moves them out by one square along the shorter side (and a bit more along the other).
  const float g = 1.0f + 2.0f / static_cast<float>(std::min(w, h) - 1);
  std::vector<cv::Point> out;
  for (const cv::Point2f& p : {tl, tr, br, bl}) {
    const cv::Point2f q = centre + (p - centre) * g;
    out.emplace_back(cvRound(q.x), cvRound(q.y));
  }
  return out;
}

}  // namespace

std::vector<BoardDetection> detectChessboards(const cv::Mat& gray_in, const BoardSpec& board_spec,
                                              const ChessboardDetectorOptions& options) {
  const cv::Size& pattern_size = board_spec.inner_corners;
  cv::Mat gray = toGray(gray_in);
  std::vector<BoardDetection> boards;
  cv::Mat work;  // copied only when a second search is needed
  const cv::Mat* search = &gray;
  int flags = cv::CALIB_CB_NORMALIZE_IMAGE;
  if (options.adaptive_threshold) flags |= cv::CALIB_CB_ADAPTIVE_THRESH;
  if (options.fast_check) flags |= cv::CALIB_CB_FAST_CHECK;
  const bool precheck = options.half_resolution_precheck && gray.cols >= 320 && gray.rows >= 240;
  // After a positive half-resolution check, OpenCV's own fast check (the same test at full
  // resolution, 3-4 ms) would only repeat it.
  if (precheck) flags &= ~cv::CALIB_CB_FAST_CHECK;
  for (int i = 0; i < options.max_boards; ++i) {
    if (precheck) {
      cv::Mat half;
      cv::resize(*search, half, cv::Size(search->cols / 2, search->rows / 2), 0, 0, cv::INTER_AREA);
      if (!cv::checkChessboard(half, pattern_size)) break;
    }
    std::vector<cv::Point2f> corners;
    // A further board is searched with a global threshold: with OpenCV's adaptive thresholds, a
    // search that fails (a board cut by the image edge, or masked) runs every block size and
    // dilation and takes 100-500 ms on the simulator's frames; this one fails in a few ms and
    // finds the same further boards there (96 of 96 on 70 frames of the sim's pivot scene).
    const int search_flags = i == 0 ? flags : (flags & ~cv::CALIB_CB_ADAPTIVE_THRESH);
    if (!cv::findChessboardCorners(*search, pattern_size, corners, search_flags)) break;
    if (static_cast<int>(corners.size()) != pattern_size.area()) break;
    BoardDetection board;
    board.corners = corners;
    boards.push_back(board);
    if (i + 1 >= options.max_boards) break;
    if (work.empty()) work = gray.clone();
    // Paint the board's area a flat mid grey: the next search cannot pick any of its corners.
    const cv::Scalar grey = cv::mean(gray);
    cv::fillConvexPoly(work, grownHull(corners, pattern_size), grey);
    search = &work;
  }
  return boards;
}

void refineCorners(const cv::Mat& gray_in, const BoardSpec& spec, BoardDetection& board,
                   const ChessboardDetectorOptions& options) {
  cv::Mat gray = toGray(gray_in);
  const double spacing = minCornerSpacingPx(board.corners, spec);
  int half = static_cast<int>(std::ceil(spacing * options.refine_window_ratio));
  half = std::clamp(half, options.refine_min_half_window_px, options.refine_max_half_window_px);
  cv::cornerSubPix(gray, board.corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-4));
}

namespace {
double percentile(std::vector<float>& v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}
}  // namespace

double edgeWidthPx(const cv::Mat& gray_in, const std::vector<cv::Point2f>& corners) {
  cv::Mat gray = toGray(gray_in);
  std::vector<cv::Point> hull;
  std::vector<cv::Point> pts;
  for (const auto& c : corners) pts.emplace_back(cvRound(c.x), cvRound(c.y));
  cv::convexHull(pts, hull);
  cv::Rect roi = cv::boundingRect(hull) & cv::Rect(0, 0, gray.cols, gray.rows);
  if (roi.width < 8 || roi.height < 8) return std::numeric_limits<double>::infinity();
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8U);
  for (auto& p : hull) p -= roi.tl();
  cv::fillConvexPoly(mask, hull, 255);
  cv::Mat patch, gx, gy;
  gray(roi).convertTo(patch, CV_32F);
  // Central differences: a sharp step edge gives a gradient of half the contrast per pixel.
  cv::Sobel(patch, gx, CV_32F, 1, 0, 1, 0.5);
  cv::Sobel(patch, gy, CV_32F, 0, 1, 1, 0.5);
  std::vector<float> values, ax, ay;
  // Percentiles do not need every pixel of a large board: sample about 20 000 of them.
  const int stride = std::max(1, static_cast<int>(std::sqrt(roi.area() / 20000.0)));
  values.reserve(static_cast<size_t>(roi.area() / (stride * stride) + 1));
  ax.reserve(values.capacity());
  ay.reserve(values.capacity());
  for (int r = 0; r < roi.height; r += stride) {
    for (int c = 0; c < roi.width; c += stride) {
      if (!mask.at<uchar>(r, c)) continue;
      values.push_back(patch.at<float>(r, c));
      ax.push_back(std::abs(gx.at<float>(r, c)));
      ay.push_back(std::abs(gy.at<float>(r, c)));
    }
  }
  const double contrast = percentile(values, 0.95) - percentile(values, 0.05);
  if (contrast < 10) return std::numeric_limits<double>::infinity();  // no edges to speak of
  // The steepest edges: a high percentile, not the maximum, so one noisy pixel does not count.
  const double gx_max = percentile(ax, 0.99), gy_max = percentile(ay, 0.99);
  const double g = std::min(gx_max, gy_max);
  if (g <= 0) return std::numeric_limits<double>::infinity();
  return contrast / g;
}

}  // namespace camera
}  // namespace autocal
