// View diversity (paper 000 §3.2, after ROS camera_calibration): each view of a board is described
// by its position X, Y, its size and its skew in the image — as ROS camera_calibration does — plus
// its distance and tilt to the camera, from a pose fitted with nominal intrinsics. A view is kept
// only when it differs enough from every kept view; coverage tells when the views span enough.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/camera/chessboard.h"
#include "autocal/camera/lens_refinement.h"

namespace autocal {
namespace camera {

/// Parameters of one view, each normalised to [0, 1].
struct ViewParams {
  double x = 0;         ///< board centre across the image (0 left, 1 right)
  double y = 0;         ///< board centre down the image
  double size = 0;      ///< sqrt(board area / image area)
  double skew = 0;      ///< 2·|90° − angle at the top-left corner| / 90°, clipped to 1
  double distance = 0;  ///< distance to the camera / ViewSelectionOptions::max_distance_m
  double tilt = 0;      ///< angle between the board normal and the optical axis / 90°
  double distance_m = 0;
  double tilt_rad = 0;
  std::array<double, 6> asArray() const { return {x, y, size, skew, distance, tilt}; }
};

struct ViewSelectionOptions {
  /// A view is kept when the L1 distance of its parameters to every kept view is at least this
  /// (ROS camera_calibration: 0.2 over X, Y, size and skew).
  double min_novelty = 0.2;
  /// Coverage goal: the spread (max − min) each parameter must reach, in its normalised unit
  /// (ROS: X 0.7, Y 0.7, size 0.4, skew 0.5; autocal adds distance and tilt).
  std::array<double, 6> goal_spread{{0.7, 0.7, 0.4, 0.5, 0.2, 0.3}};
  /// Coverage is sufficient when every spread reaches its goal and at least min_views are kept,
  /// or when max_views are kept (ROS: 40).
  int min_views = 10;
  int max_views = 40;
  /// Nominal focal length for the distance/tilt pose, as a fraction of the image width [1].
  double nominal_focal_width_ratio = 0.85;
  /// Distance that maps to 1 in ViewParams::distance [m].
  double max_distance_m = 3.0;
  /// Views whose edges are wider than this are refused as blurred [px] (see edgeWidthPx: a
  /// perfectly sharp edge measures 2 px, OpenCV's sample photos 2.6–3.4 px, a Gaussian blur of
  /// sigma 3 px more than 6 px).
  double max_edge_width_px = 5.0;
  /// A board is refused when a corner lies nearer the image's edge than this many of its own
  /// corner spacings (distance to its nearest neighbouring corner): the squares around it are cut
  /// by the edge and the detector may place it wrong (a floor board's corner 9 px from the edge,
  /// 0.2 spacings, 11.6 px off the true lens's fit; OpenCV's sample photos have corners at 0.87
  /// spacings, found right). 0 turns the check off [1].
  double min_edge_distance_spacings = 0.5;
  /// Also keep every sharp board (refined), novel or not: novelty decides when the views cover
  /// enough, but the fit gains from every sharp view (the simulator's narrow-lens sweep: principal
  /// point 0.36 px from the truth from 17 novel views, 0.09 px from all 42 sharp ones). Costs a
  /// sub-pixel refinement per board.
  bool keep_sharp_views = true;
};

/// The parameters of a board view in an image of the given size.
ViewParams computeViewParams(const std::vector<cv::Point2f>& corners, const cv::Size& image_size,
                             const BoardSpec& board, const ViewSelectionOptions& options);

struct Coverage {
  std::array<double, 6> spread{};    ///< max − min of each parameter over the kept views
  std::array<double, 6> progress{};  ///< spread / goal, clipped to 1
  int views = 0;
  bool sufficient = false;
  /// One line, e.g. "X 0.62 Y 1.00 size 0.40 skew 0.10 dist 0.30 tilt 0.55, 12 views".
  std::string summary() const;
};

/// A kept view: refined corners of one board, and what it was judged on.
struct CalibrationView {
  std::vector<cv::Point2f> corners;
  ViewParams params;
  double edge_width_px = 0;
  std::string source;  ///< file name or "bag:<topic>@<stamp>"
  int frame_index = -1;
  /// The board's grey pixels, kept with ChessboardDetectorOptions::refine_through_lens.
  BoardPatch patch;
};

/// What happened to one board found in a frame.
struct ViewDecision {
  bool kept = false;
  /// Whole, finite and sharp: calibrated on when ViewSelectionOptions::keep_sharp_views, kept or
  /// not.
  bool sharp = false;
  std::string reason;  ///< why it was refused, or "kept"
  ViewParams params;
  double edge_width_px = 0;
  std::vector<cv::Point2f> corners;
};

/// A board found in a frame, judged on what needs no other frame.
struct DetectedBoard {
  std::vector<cv::Point2f> corners;  ///< as detected (the view's judgement uses these)
  std::vector<cv::Point2f> refined;  ///< sub-pixel refined; only when sharp
  double edge_width_px = 0;
  /// Whole, finite, sharp and clear of the image's edge (see ViewSelectionOptions).
  bool sharp = false;
  /// Its grey pixels when sharp (ChessboardDetectorOptions::refine_through_lens).
  BoardPatch patch;
};

/// The boards ViewCollector::detect found in one frame.
struct DetectedFrame {
  cv::Size image_size;
  std::vector<DetectedBoard> boards;
};

struct FrameResult {
  int boards_found = 0;
  std::vector<ViewDecision> decisions;
  bool any_kept() const;
};

/// Takes frames one at a time (from a robot turning past boards, or from files) and keeps the
/// views worth calibrating on. Detection is the fast one; only kept views are refined.
class ViewCollector {
 public:
  ViewCollector(const BoardSpec& board, const ChessboardDetectorOptions& detector,
                const ViewSelectionOptions& selection);

  /// Detects boards in `image` (8-bit, grey or colour) and keeps the views that are sharp and
  /// new. Throws InputError when the image is empty or of another size than the first one.
  FrameResult addFrame(const cv::Mat& image, const std::string& source);
  /// addFrame in two parts, so that frames can be detected on several threads and added in
  /// order with the same result: detect() reads nothing the collector changes (it may run on
  /// several frames at once while no add() runs); add() judges the boards against the views kept
  /// so far. detect() throws InputError for an empty image, add() for another size than the first
  /// frame's.
  DetectedFrame detect(const cv::Mat& image, const std::string& source) const;
  FrameResult add(DetectedFrame frame, const std::string& source);
  /// The same for corners found elsewhere (tests, replays): judged but not re-detected.
  ViewDecision addView(const std::vector<cv::Point2f>& corners, const cv::Size& image_size,
                       double edge_width_px, const std::string& source);

  /// The views kept for their novelty (coverage).
  const std::vector<CalibrationView>& views() const { return views_; }
  /// Every sharp board seen, kept or not (empty unless ViewSelectionOptions::keep_sharp_views).
  const std::vector<CalibrationView>& sharpViews() const { return sharp_views_; }
  /// The views to calibrate on: sharpViews() when kept, else views().
  const std::vector<CalibrationView>& calibrationViews() const {
    return selection_.keep_sharp_views ? sharp_views_ : views_;
  }
  Coverage coverage() const;
  const cv::Size& imageSize() const { return image_size_; }
  const BoardSpec& board() const { return board_; }
  int frames() const { return frames_; }

 private:
  ViewDecision judge(const std::vector<cv::Point2f>& corners, double edge_width_px);
  bool usableAndSharp(const std::vector<cv::Point2f>& corners, double edge_width_px,
                      const cv::Size& image_size) const;
  /// Whether a sharp view already has these corners (within 0.001 px each): a repeated frame (a
  /// camera driver that sends its last frame again, a simulator standing still) is not a new
  /// measurement, and counted again it would shrink the fit's uncertainty as if it were.
  bool repeatsSharpView(const std::vector<cv::Point2f>& corners) const;
  /// Why the board's corners are too near the image's edge to trust, or "" (see
  /// ViewSelectionOptions::min_edge_distance_spacings).
  std::string nearEdge(const std::vector<cv::Point2f>& corners, const cv::Size& image_size) const;

  BoardSpec board_;
  ChessboardDetectorOptions detector_;
  ViewSelectionOptions selection_;
  cv::Size image_size_;
  std::vector<CalibrationView> views_;
  std::vector<CalibrationView> sharp_views_;
  int frames_ = 0;
};

}  // namespace camera
}  // namespace autocal
