// The focus assistant's measure (paper 000 §6, its future work: "the operator will be provided
// with an interface displaying the current value of the sharpness metric and its maximum, which
// will be reached when passing through the sharpness point"). A person turns the lens ring; each
// frame's board is measured by the width of its edges (edgeWidthPx, the camera stage's own blur
// measure), and the sharpest value seen so far is kept. The person turns through the peak and back
// to it. No ROS.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "autocal/camera/chessboard.h"

namespace autocal {
namespace camera {

struct FocusMeterOptions {
  BoardSpec board;
  ChessboardDetectorOptions detector;
  /// A reading within this share of the best counts as at the peak [0..1].
  double at_best_fraction = 0.95;
  /// Throws ConfigError naming the bad key.
  void validate() const;
};

/// One frame's measure.
struct FocusReading {
  double stamp_s = 0;
  bool board = false;        ///< a board was found (no board: no sharpness this frame)
  double edge_width_px = 0;  ///< its edges' width [px]: 2 for a perfectly sharp edge
  double sharpness = 0;      ///< 2 / edge width: 1 for a perfectly sharp edge, 0 when no board
  double best = 0;           ///< the sharpest value so far
  double best_stamp_s = 0;   ///< when it was seen
  bool at_best = false;      ///< sharpness >= at_best_fraction · best
  std::vector<cv::Point2f> corners;  ///< the board measured
  /// One line for a person: "sharpness 0.82 (best 0.91, 90 %): turn back to the best".
  std::string describe() const;
};

class FocusMeter {
 public:
  /// Throws ConfigError on bad options.
  explicit FocusMeter(const FocusMeterOptions& options);
  /// Measures an 8-bit frame (grey or colour) taken at `stamp_s`.
  FocusReading add(double stamp_s, const cv::Mat& image);
  /// Forgets the best (after the lens was changed for good).
  void reset();
  const FocusReading& last() const { return last_; }

 private:
  FocusMeterOptions options_;
  FocusReading last_;
  double best_ = 0, best_stamp_s_ = 0;
};

/// The frame with the board's outline, a bar of the sharpness with the best marked, and the
/// reading's line: what focus_node shows on camera_view/image (BGR).
cv::Mat drawFocus(const cv::Mat& image, const FocusReading& reading);

}  // namespace camera
}  // namespace autocal
