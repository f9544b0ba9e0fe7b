// Renders the robot's camera image from its true pose: the floor (with AprilTags drawn from the
// tag family's own code bits, and lane lines), vertical chessboards on stands, textured walls and
// boxes, seen through the TRUE intrinsics and distortion.
//
// Each pixel integrates its area (anti-aliasing): pixel corners are traced once; where a pixel's
// corners disagree (an edge crosses it) it is supersampled on an s x s grid, so that corners and
// edges land where the geometry puts them to a small fraction of a pixel. Several robot poses
// spread over the exposure are averaged (motion blur); Gaussian noise is added last.
//
// The rays are traced through tracing::RayTracer (sim/src/ray_tracer.h). A frame reuses the
// renderer's buffers (the corners' colours, the last still image, the blur accumulator), so
// rendering changes the renderer and is not const: one renderer per thread.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "autocal/sim/camera_model.h"
#include "autocal/sim/config.h"

namespace autocal {
namespace sim {

struct RenderOptions {
  int supersampling = 3;        ///< an edge pixel gets supersampling^2 samples (Hammersley set)
  /// A pixel is supersampled when its corners lie on different surfaces, or their colours differ
  /// by more than this [grey levels] (sharp marks on one surface: squares, tag cells, lane lines;
  /// smooth texture below it is interpolated).
  double edge_threshold = 24.0;
  double noise_sigma = 2.0;     ///< Gaussian pixel noise [grey levels]
  uint64_t noise_seed = 1;      ///< seed of the noise table
  /// A still frame (one pose) reuses the noiseless image of the last still frame rendered when
  /// the camera has moved since by so little that no image point moved by more than this [px]
  /// (0: only at the same pose; negative: never reuse, render every frame anew). Fresh noise is
  /// drawn for every frame either way. A robot standing between stop-and-shoot pulses images the
  /// same scene frame after frame; its wheels' first-order lag lets it creep by ever smaller
  /// amounts for about 0.6 s before it stops exactly, and 0.01 px is far below the renderer's
  /// accuracy (corners within 0.15 px) and the noise.
  double still_reuse_px = 0.01;
  /// A blurred frame's 4 x 4 blends summed over its poses (their corners' colours) and blended
  /// once, not added into the image at every pose (the same image up to float rounding). False:
  /// every pose's blends added into the image (the code before; for the benchmark's side-by-side).
  bool blur_block_sums = true;
  /// A blurred frame of at least this many poses (the simulator takes about one pose per pixel
  /// the image moves during the exposure) renders n / 2 + 1 of its n poses (the first and the
  /// last, none more than two apart: still about one per pixel of that resolution) at half
  /// resolution, 2 x 2 pixels to a pixel, and scales the average up (bilinear): about a sixth of
  /// the rays. Its motion smears it by
  /// at least this many pixels along the motion anyway; across the motion it is softened by about
  /// one pixel more than the full-resolution poses would give. 0: every pose at full resolution
  /// (the code before; for the benchmark's side by side). Still frames never change.
  int blur_half_res_poses = 4;
  /// An edge pixel whose four corners lie on one plane (a board, the floor, a wall: the edges of
  /// squares, tags, lines and posters) colours its samples at their points on that plane,
  /// interpolated between its corners', instead of tracing a ray through the scene for each.
  /// False: every sample traced (the code before; for the benchmark's side by side).
  bool edge_samples_on_plane = true;
};

namespace tracing {
class RayTracer;
struct TraceView;
}  // namespace tracing
namespace detail {
/// A linear colour, 0..255 per channel, in OpenCV's BGR order.
struct Rgb {
  float b = 0, g = 0, r = 0;
};
}  // namespace detail

class Renderer {
 public:
  Renderer(const CameraConfig& camera, const WorldConfig& world, const RenderOptions& options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// The image (CV_8UC3, BGR) seen from the average of these robot poses over the exposure (one
  /// pose: a still image). With several poses (motion blur) the sub-frames are not anti-aliased:
  /// their average blurs the edges far more than a pixel, and it keeps blurred frames cheap. `rng` draws the noise offsets, so a seeded rng gives the same image.
  cv::Mat render(const std::vector<Pose2>& poses, std::mt19937_64& rng);

  /// A rolling shutter's frame: the image's rows in bands of rollingBandRows() rows from the top,
  /// each band seen from the average of its own poses (its rows' exposure); every band is rendered
  /// anew (no still-frame reuse, no half resolution).
  cv::Mat renderRolling(const std::vector<std::vector<Pose2>>& bands, std::mt19937_64& rng);
  /// Rows per band of renderRolling (the last band may have fewer).
  int rollingBandRows() const;

  /// The focus ring's defocus from now on [px]: a Gaussian blur of this sigma before the noise (0:
  /// sharp). With the camera's depth of field (CameraConfig::focus_distance_m and
  /// defocus_px_per_diopter) it adds to each surface's own blur, signed (the ring turned one way
  /// or the other moves the focus nearer or farther).
  void setDefocusPx(double sigma_px) { defocus_px_ = sigma_px; }

  /// The noiseless linear image (CV_32FC3, BGR, 0..255) of one pose; for tests.
  cv::Mat renderExact(const Pose2& pose);

  /// Blurred frames rendered at half resolution (see RenderOptions::blur_half_res_poses).
  uint64_t blurredFramesHalfRes() const { return blurred_half_res_; }

  const CameraModel& camera() const { return camera_; }


  /// Still frames rendered anew and still frames that reused the last one's noiseless image.
  uint64_t stillFramesRendered() const { return still_rendered_; }
  uint64_t stillFramesReused() const { return still_reused_; }

  /// Largest motion [px] of an image point between these two camera poses, for a scene no nearer
  /// than nearest_m to the camera (an upper bound: the turn plus the shift seen at nearest_m).
  double imageMotionBoundPx(const Pose2& a, const Pose2& b, double nearest_m) const;

 private:
  /// Adds the image of one pose to `accumulate` (store: writes it, every pixel); with sum_blocks (a
  /// blurred frame, image sides multiples of 4), the 4 x 4 blocks it blends add their corners'
  /// colours to block_sums_ instead. Only the rows [v_begin, v_end) (multiples of the block size).
  void renderPose(const Pose2& pose, bool antialias, bool sum_blocks, bool store,
                  float* accumulate, int v_begin, int v_end);
  /// The frame from its noiseless linear image: defocus, brightness, vignetting, noise, 8 bits.
  /// same_scene: the noiseless image is the last still's, reused (its defocus may be too).
  cv::Mat finish(const cv::Mat& linear, bool same_scene, std::mt19937_64& rng);
  bool depthOfField() const;
  /// With a depth of field: each grid point's distance to the scene from this pose (depth_grid_).
  void traceDepths(const Pose2& pose);
  /// The defocused image: blurred by the ring alone, or per pixel by its distance's blur.
  const cv::Mat& defocus(const cv::Mat& linear, bool same_scene);
  /// The noiseless linear image (CV_32FC3) of these poses' average: a buffer of this renderer
  /// (the last still frame's image, or the blur accumulator), valid until the next call.
  const cv::Mat& renderNoiseless(const std::vector<Pose2>& poses);

  CameraConfig config_;
  CameraModel camera_;
  RenderOptions options_;
  std::unique_ptr<tracing::RayTracer> tracer_;  ///< the world, as surfaces a ray can hit
  /// The tracer's bins for the pose being rendered (RayTracer::prepare), rebuilt per pose.
  std::unique_ptr<tracing::TraceView> view_;
  int width_ = 0, height_ = 0;
  // Pixel-corner grid ((width+1) x (height+1)): ray direction in the robot frame, its azimuth bin.
  std::vector<Eigen::Vector3f> corner_dirs_;
  std::vector<uint16_t> corner_bins_;
  std::vector<uint8_t> corner_valid_;
  std::vector<uint8_t> block4_valid_;  ///< per 4 x 4 pixel block: all its corners are valid rays
  // Per-frame buffers of the corners' colours (BGR) and surface ids, kept between frames.
  std::vector<detail::Rgb> corner_color_;
  std::vector<int> corner_id_;
  std::vector<Eigen::Vector2f> corner_plane_;  // where a corner's ray meets its surface
  std::vector<detail::Rgb> block_sums_;  // blurred frame: per 4 x 4 block, its corners' sums
  std::vector<uint8_t> block_summed_;     // ... and whether any pose blended it
  std::vector<uint32_t> traced_;          // frame number in which a corner was traced
  uint32_t frame_ = 0;
  std::vector<Eigen::Vector2f> sample_offsets_;  // sample positions within a pixel, in [0, 1)^2
  std::vector<float> noise_table_;
  double px_per_rad_ = 0;  ///< largest image motion [px] per radian a ray turns (finest pixel)
  // The last still frame: its noiseless image, pose and nearest traced surface [m].
  cv::Mat still_image_;
  Pose2 still_pose_;
  double still_nearest_m_ = 0;
  double nearest_m_ = 0;
  cv::Mat vignette_;  ///< each pixel's brightness factor (CameraConfig::vignetting); empty: none
  cv::Mat accumulator_, noisy_row_, shaded_row_;  ///< per-frame buffers, kept between frames
  uint64_t still_rendered_ = 0, still_reused_ = 0, blurred_half_res_ = 0;
  double defocus_px_ = 0;
  cv::Mat defocused_;  // the defocused noiseless image (a buffer kept between frames)
  bool defocused_valid_ = false;  // defocused_ holds the last frame's blur ...
  double defocused_for_px_ = 0;   // ... with the ring at this defocus ...
  const uchar* defocused_from_ = nullptr;  // ... of this noiseless buffer
  /// Depth of field: the scene's distance [m] through every kDepthStep-th pixel corner (rows by
  /// columns; +inf: nothing hit), of the last pose rendered anew, and the blurred levels.
  cv::Mat depth_grid_, sigma_map_, still_depth_grid_;  // the last still's own distances
  std::vector<cv::Mat> levels_;
  /// The same camera at half resolution, for blurred frames of many poses (null: not used).
  std::unique_ptr<Renderer> half_;
  cv::Mat upscaled_;
};

class Simulation;

/// The frame the robot's camera captures at capture_s (its exposure, or with a rolling shutter its
/// readout, ending then): motion-blurred over the exposure's poses (at most max_blur_samples), and
/// with CameraConfig::readout_s > 0 each band of rows at its own time (one still image when the
/// robot stood still over the whole readout). What sim_node publishes.
cv::Mat renderFrame(Renderer& renderer, const Simulation& simulation, double capture_s,
                    int max_blur_samples, std::mt19937_64& rng);

}  // namespace sim
}  // namespace autocal
