// Chessboard detection for camera calibration: a fast per-frame detector (classic OpenCV detector
// with its fast check), several boards of the same size per frame without mixing their corners,
// sub-pixel refinement for the views that are kept, and a blur metric that refuses soft views.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace autocal {
namespace camera {

/// The calibration board, given once and passed to detection, view selection and calibration.
struct BoardSpec {
  /// Inner corners per row (cols) and per column (rows), e.g. 9x6 (not squares).
  cv::Size inner_corners{9, 6};
  double square_size_m = 0.025;  ///< side of one square [m]

  /// The board's corners in its own frame [m], in OpenCV's row-major pattern order.
  std::vector<cv::Point3f> points() const;
  int cornerCount() const { return inner_corners.area(); }
  /// "9x6, 0.025 m squares".
  std::string describe() const;
  /// Throws ConfigError naming board.inner_corners or board.square_size_m.
  void validate() const;
};

struct ChessboardDetectorOptions {
  /// At most this many boards are searched for in one frame.
  int max_boards = 4;
  /// Use OpenCV's fast check (rejects frames without a board in a few ms) when the
  /// half-resolution precheck below is off or the image is smaller than 320x240 (after a positive
  /// precheck it would only repeat the same test at full resolution).
  bool fast_check = true;
  /// Before each search, run cv::checkChessboard on a half-resolution copy (1–4 ms on 640x480)
  /// and skip the full search when it finds no board: frames without a board, and the repeated
  /// search after the last board of a frame, cost that much instead of 10–100 ms. Boards whose
  /// squares are smaller than about 10 px may be missed; turn off for such images.
  bool half_resolution_precheck = true;
  /// OpenCV's adaptive thresholds (cv::CALIB_CB_ADAPTIVE_THRESH) in the first search of a frame
  /// (further searches always use one global threshold). They help with uneven light, but a
  /// search that finds no board then tries every block size and dilation: 100-1200 ms on frames
  /// where a board is cut by the image's edge, as when the robot turns past its boards. Off by
  /// default: the global threshold finds the same boards in OpenCV's sample photos and the
  /// simulator's frames.
  bool adaptive_threshold = false;
  /// Sub-pixel window half-size as a fraction of the smallest corner spacing in the view. A window
  /// that reaches the neighbouring corners (ROS camera_calibration uses 0.5) pulls corners off the
  /// true saddle point: on OpenCV's sample photos 0.5 gives 1.3 px held-out error, 0.3 gives 0.19.
  double refine_window_ratio = 0.3;
  /// Bounds of the sub-pixel window half-size [px].
  int refine_min_half_window_px = 2;
  int refine_max_half_window_px = 11;
  /// Keep each view's board pixels (40-100 kB a view) and, before the calibration, refine its
  /// corners again through the lens a first fit of them finds (refineThroughLens): a wide lens
  /// bends the squares' edges, and the plain refinement's radial bias of a few hundredths of a
  /// pixel, taken for distortion by the fit, put the simulator's wide lens 0.66 px RMS off over
  /// the image instead of 0.18 px.
  bool refine_through_lens = true;
};

/// One board found in a frame: corners in OpenCV's row-major order of the pattern.
struct BoardDetection {
  std::vector<cv::Point2f> corners;
};

/// Finds up to options.max_boards boards of the given size in a grey image. After each board is
/// found, its hull (grown by one square) is painted over and the search is repeated, so every
/// returned board has corners from one physical board only. Corners are not yet refined.
std::vector<BoardDetection> detectChessboards(const cv::Mat& gray, const BoardSpec& board,
                                              const ChessboardDetectorOptions& options);

/// Smallest distance between neighbouring corners of a board [px].
double minCornerSpacingPx(const std::vector<cv::Point2f>& corners, const BoardSpec& board);

/// Sub-pixel refinement with a window scaled to the board's own corner spacing.
void refineCorners(const cv::Mat& gray, const BoardSpec& spec, BoardDetection& board,
                   const ChessboardDetectorOptions& options);

/// Blur of the board region, as the width of its edges [px]: contrast (95th − 5th percentile of
/// grey) over the steepest gradient (99th percentile of central differences), in x and in y
/// separately, the larger one returned so that motion blur along one axis shows. A perfectly
/// sharp edge measures 2 px; a Gaussian blur of sigma s widens it to about 2.5 s. Paper 000 §6
/// asks for a sharpness metric (it cites a DCT-based one, ref. 13); on a chessboard the edge
/// width is cheaper, does not depend on the board's scale in the image, and its threshold has a
/// unit a user can reason about.
double edgeWidthPx(const cv::Mat& gray, const std::vector<cv::Point2f>& corners);

/// Converts any 8-bit 1/3/4-channel image to grey; throws InputError for other types.
cv::Mat toGray(const cv::Mat& image);

}  // namespace camera
}  // namespace autocal
