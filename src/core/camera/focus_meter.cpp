// The focus assistant's measure (paper 000 §6); see focus_meter.h.
#include "autocal/camera/focus_meter.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace camera {

void FocusMeterOptions::validate() const {
  board.validate();
  checkConfig(at_best_fraction > 0 && at_best_fraction <= 1, "at_best_fraction",
              "must be within (0, 1]");
}

std::string FocusReading::describe() const {
  if (!board) {
    return "no board in view (best so far " + formatNumber(best, 3) +
           "): show the camera a board, near the middle of the image";
  }
  const int percent = best > 0 ? static_cast<int>(std::lround(100 * sharpness / best)) : 100;
  return "sharpness " + formatNumber(sharpness, 3) + " (edges " + formatNumber(edge_width_px, 3) +
         " px; best " + formatNumber(best, 3) + ", " + std::to_string(percent) + " %): " +
         (at_best ? "at the best seen: stop here, or turn on to look for a better one"
                  : "turn back towards the best");
}

FocusMeter::FocusMeter(const FocusMeterOptions& options) : options_(options) {
  options_.validate();
}

void FocusMeter::reset() {
  best_ = 0;
  best_stamp_s_ = 0;
}

FocusReading FocusMeter::add(double stamp_s, const cv::Mat& image) {
  const cv::Mat gray = toGray(image);
  FocusReading r;
  r.stamp_s = stamp_s;
  ChessboardDetectorOptions detector = options_.detector;
  detector.max_boards = 1;  // the largest sharpness of one board is what the person watches
  const std::vector<BoardDetection> boards = detectChessboards(gray, options_.board, detector);
  if (!boards.empty()) {
    r.board = true;
    r.corners = boards.front().corners;
    r.edge_width_px = edgeWidthPx(gray, r.corners);
    r.sharpness = r.edge_width_px > 0 ? std::min(1.0, 2.0 / r.edge_width_px) : 0.0;
    if (r.sharpness > best_) best_ = r.sharpness, best_stamp_s_ = stamp_s;
  }
  r.best = best_;
  r.best_stamp_s = best_stamp_s_;
  r.at_best = r.board && r.sharpness >= options_.at_best_fraction * best_;
  last_ = r;
  return r;
}

cv::Mat drawFocus(const cv::Mat& image, const FocusReading& reading) {
  cv::Mat out;
  if (image.channels() == 1) {
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  } else {
    out = image.clone();
  }
  const cv::Scalar green(0, 200, 0), orange(0, 140, 255), white(255, 255, 255), black(0, 0, 0);
  if (reading.board && reading.corners.size() >= 4) {
    std::vector<cv::Point> hull;
    std::vector<cv::Point> pts(reading.corners.begin(), reading.corners.end());
    cv::convexHull(pts, hull);
    cv::polylines(out, hull, true, reading.at_best ? green : orange, 2);
  }
  // The bar along the bottom: the sharpness (0..1), the best as a white tick.
  const int h = std::max(12, out.rows / 24), y = out.rows - h - 28;
  const cv::Rect bar(10, y, out.cols - 20, h);
  cv::rectangle(out, bar, black, cv::FILLED);
  const int filled = static_cast<int>(bar.width * std::clamp(reading.sharpness, 0.0, 1.0));
  if (filled > 0) {
    cv::rectangle(out, cv::Rect(bar.x, bar.y, filled, bar.height), reading.at_best ? green : orange,
                  cv::FILLED);
  }
  const int best_x = bar.x + static_cast<int>(bar.width * std::clamp(reading.best, 0.0, 1.0));
  cv::line(out, {best_x, bar.y - 4}, {best_x, bar.y + bar.height + 4}, white, 2);
  cv::rectangle(out, bar, white, 1);
  const std::string line = reading.describe();
  cv::putText(out, line.substr(0, 90), {10, out.rows - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.42, black,
              3);
  cv::putText(out, line.substr(0, 90), {10, out.rows - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.42, white,
              1);
  return out;
}

}  // namespace camera
}  // namespace autocal
