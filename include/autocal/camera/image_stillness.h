// Whether the camera stands still, judged from its own frames: the shift of the whole image between
// two frames (phase correlation, and below a pixel the image gradients) over the time between
// their stamps. The encoders cannot see the end of a stop: a wheel coasting to rest turns less
// than one tick between readings long before it stands (1 tick of a Duckiebot's 135 is 1.5 mm of
// wheel), while the image still moves by a pixel a second or more and smears a view taken then. A
// camera wobbling on its mount after a stop shows here too, and nowhere in the encoders. No ROS.
#pragma once

#include <opencv2/core.hpp>

namespace autocal {
namespace camera {

struct ImageStillnessOptions {
  /// The image counts as still when it moved no faster than this between two frames [px/s] (full
  /// resolution); 0: every frame counts as still (the encoders alone decide). 3 px/s moves a
  /// corner 0.1 px over a 30 fps frame's readout.
  double max_speed_px_s = 3.0;
  /// The frames are compared at 1/downsample of their size (the shift is scaled back) [1].
  int downsample = 2;
  /// A phase-correlation peak below this response is no measurement (a scene without texture,
  /// or one that changed); the frames then do not count as still [0..1].
  double min_response = 0.05;
  /// A shift below a pixel is measured from the image gradients (Lucas-Kanade over the whole
  /// image); an image whose mean squared gradient in its weakest direction is below this (at the
  /// compared size) shows no motion along it: no measurement [grey levels²/px²].
  double min_gradient = 1.0;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// Consecutive frames of one stop in; whether the last one shows a still image.
class ImageStillness {
 public:
  /// Throws ConfigError for invalid options.
  explicit ImageStillness(const ImageStillnessOptions& options);

  bool enabled() const { return options_.max_speed_px_s > 0; }
  /// A new stop: the frames before it are not compared with the next.
  void reset();
  /// Adds the frame stamped `stamp_s` (8-bit grey or colour): true when it is the second or later
  /// frame since reset() and the image moved no faster than max_speed_px_s since the frame before
  /// (always true when not enabled). A frame stamped no later than the one before replaces it.
  bool add(double stamp_s, const cv::Mat& image);
  /// The image's speed between the last two frames [px/s] (-1: none measured yet, or no
  /// measurement: see min_response and min_gradient).
  double lastSpeedPxS() const { return last_speed_px_s_; }

 private:
  ImageStillnessOptions options_;
  cv::Mat previous_, window_;
  double previous_s_ = 0;
  double last_speed_px_s_ = -1;
};

}  // namespace camera
}  // namespace autocal
