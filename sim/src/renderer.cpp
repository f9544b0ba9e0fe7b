#include "autocal/sim/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/sim/scene.h"
#include "autocal/sim/simulation.h"
#include "ray_tracer.h"

namespace autocal {
namespace sim {

using namespace tracing;  // NOLINT: the tracer's constants and colours

namespace {

/// Adds to (kStore: writes into) an n x n block of pixels at (u, v) of a BGR float image `width`
/// pixels wide the bilinear blend of its outer corners' colours (a top left, b top right, e bottom
/// left, f bottom right).
template <bool kStore>
void blendBlock(float* acc, int width, int u, int v, int n, const Rgb& ca, const Rgb& cb,
                const Rgb& ce, const Rgb& cf) {
  const float inv = 1.0f / static_cast<float>(n);
  for (int j = 0; j < n; ++j) {
    const float y = (static_cast<float>(j) + 0.5f) * inv;
    // The row's ends, then steps along it.
    const float lb = ca.b + (ce.b - ca.b) * y, lg = ca.g + (ce.g - ca.g) * y,
                lr = ca.r + (ce.r - ca.r) * y;
    const float db = (cb.b + (cf.b - cb.b) * y - lb) * inv,
                dg = (cb.g + (cf.g - cb.g) * y - lg) * inv,
                dr = (cb.r + (cf.r - cb.r) * y - lr) * inv;
    float* out = acc + 3 * (static_cast<size_t>(v + j) * width + u);
    for (int i = 0; i < n; ++i, out += 3) {
      const float x = static_cast<float>(i) + 0.5f;
      if (kStore) {
        out[0] = lb + db * x;
        out[1] = lg + dg * x;
        out[2] = lr + dr * x;
      } else {
        out[0] += lb + db * x;
        out[1] += lg + dg * x;
        out[2] += lr + dr * x;
      }
    }
  }
}

}  // namespace

// -----------------------------------------------------------------------------------------------

Renderer::Renderer(const CameraConfig& camera, const WorldConfig& world,
                   const RenderOptions& options)
    : config_(camera),
      camera_(camera.truth),
      options_(options),
      tracer_(std::make_unique<RayTracer>(world)),
      view_(std::make_unique<TraceView>()),
      width_(camera.truth.width),
      height_(camera.truth.height) {
  if (options_.supersampling < 1 || options_.supersampling > 16) {
    throw ConfigError("renderer: supersampling must be 1..16");
  }
  // Rays through the pixel corners (OpenCV: pixel centres at integers, so corners at half
  // integers), turned into the robot frame once: the camera is fixed on the robot.
  const Eigen::Matrix3d robot_cam = cameraToRobotRotation(camera);
  const size_t n = static_cast<size_t>((width_ + 1) * (height_ + 1));
  corner_dirs_.resize(n);
  corner_bins_.resize(n);
  corner_valid_.resize(n);
  for (int v = 0; v <= height_; ++v) {
    for (int u = 0; u <= width_; ++u) {
      const size_t i = static_cast<size_t>(v * (width_ + 1) + u);
      Eigen::Vector3d ray;
      const bool ok = camera_.ray(u - 0.5, v - 0.5, &ray);
      corner_valid_[i] = ok;
      const Eigen::Vector3d d = ok ? Eigen::Vector3d(robot_cam * ray) : Eigen::Vector3d(0, 0, 1);
      corner_dirs_[i] = d.cast<float>();
      const double horizontal = std::hypot(d.x(), d.y());
      corner_bins_[i] = horizontal < 0.02 ? kAllBins
                                          : static_cast<uint16_t>(azimuthBin(std::atan2(d.y(), d.x())));
    }
  }
  // A 4 x 4 block may be blended from its outer corners only if all its 25 corners are valid rays.
  if (width_ % 4 == 0 && height_ % 4 == 0) {
    block4_valid_.assign(static_cast<size_t>((width_ / 4) * (height_ / 4)), 1);
    for (int v = 0; v <= height_; ++v) {
      for (int u = 0; u <= width_; ++u) {
        if (corner_valid_[static_cast<size_t>(v * (width_ + 1) + u)]) continue;
        // This corner belongs to the blocks on either side of it.
        for (int bv : {v / 4 - (v % 4 == 0 ? 1 : 0), v / 4}) {
          for (int bu : {u / 4 - (u % 4 == 0 ? 1 : 0), u / 4}) {
            if (bv >= 0 && bu >= 0 && bv < height_ / 4 && bu < width_ / 4) {
              block4_valid_[static_cast<size_t>(bv * (width_ / 4) + bu)] = 0;
            }
          }
        }
      }
    }
  }
  // Sample positions within an edge pixel: a Hammersley set of ss^2 points (one per row and per
  // column of the ss^2 x ss^2 grid), which measures the area an edge covers in ss^2 steps
  // whatever its direction, where a regular ss x ss grid has only ss steps for axis-aligned edges.
  const int n_samples = options_.supersampling * options_.supersampling;
  for (int i = 0; i < n_samples; ++i) {
    double radical = 0, f = 0.5;
    for (int k = i; k > 0; k >>= 1, f *= 0.5) radical += f * (k & 1);
    // Radical inverse in base 2 is a permutation only for powers of two; rank it among the set.
    sample_offsets_.emplace_back(static_cast<float>((i + 0.5) / n_samples), static_cast<float>(radical));
  }
  std::vector<int> order(n_samples);
  for (int i = 0; i < n_samples; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return sample_offsets_[a].y() < sample_offsets_[b].y(); });
  for (int rank = 0; rank < n_samples; ++rank) {
    sample_offsets_[order[rank]].y() = static_cast<float>((rank + 0.5) / n_samples);
  }
  // The finest angular pixel pitch bounds how far a turned ray moves in the image.
  double finest_rad = std::numeric_limits<double>::infinity();
  for (int v = 0; v <= height_; ++v) {
    for (int u = 0; u <= width_; ++u) {
      const size_t i = static_cast<size_t>(v * (width_ + 1) + u);
      if (!corner_valid_[i]) continue;
      if (u < width_ && corner_valid_[i + 1]) {
        finest_rad = std::min(finest_rad, static_cast<double>((corner_dirs_[i + 1] - corner_dirs_[i]).norm()));
      }
      if (v < height_ && corner_valid_[i + width_ + 1]) {
        finest_rad = std::min(finest_rad, static_cast<double>((corner_dirs_[i + width_ + 1] - corner_dirs_[i]).norm()));
      }
    }
  }
  px_per_rad_ = std::isfinite(finest_rad) && finest_rad > 0 ? 1.0 / finest_rad : 0.0;
  // A table of standard normal samples, four images long, so that a frame's noise never repeats
  // within the frame; each frame starts at a random offset (drawn from the caller's seeded rng).
  // Half resolution for blurred frames of many poses: half-pixel (u', v') covers pixels 2u'..2u'+1,
  // so its centre 2u' + 0.5 is pixel coordinate u: u' = (u - 0.5) / 2 (cv::resize's bilinear
  // scaling by 2 samples it there).
  if (options_.blur_half_res_poses > 0 && width_ % 8 == 0 && height_ % 8 == 0) {
    CameraConfig half = camera;
    half.truth.width = width_ / 2;
    half.truth.height = height_ / 2;
    half.truth.fx = 0.5 * camera.truth.fx;
    half.truth.fy = 0.5 * camera.truth.fy;
    half.truth.cx = 0.5 * (camera.truth.cx - 0.5);
    half.truth.cy = 0.5 * (camera.truth.cy - 0.5);
    half.vignetting = 0.0;  // the shading is applied once, to the full-resolution frame
    half.brightness_sigma = 0.0;
    RenderOptions half_options = options_;
    half_options.blur_half_res_poses = 0;
    half_options.supersampling = 1;
    half_options.noise_sigma = 0;
    half_ = std::make_unique<Renderer>(half, world, half_options);
  }
  std::mt19937_64 gen(options_.noise_seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  // (A renderer without noise, the half-resolution one, keeps no table.)
  noise_table_.resize(options_.noise_sigma > 0 ? static_cast<size_t>(width_) * height_ * 3 * 4 : 0);
  for (float& x : noise_table_) x = normal(gen);
  // Vignetting: brightness falls with the square of the distance from the principal point, by
  // `vignetting` at the farthest image corner.
  if (camera.vignetting > 0) {
    const double cx = camera.truth.cx, cy = camera.truth.cy;
    double corner2 = 0;
    for (double u : {-0.5, width_ - 0.5}) {
      for (double v : {-0.5, height_ - 0.5}) corner2 = std::max(corner2, (u - cx) * (u - cx) + (v - cy) * (v - cy));
    }
    vignette_.create(height_, width_, CV_32FC3);
    for (int v = 0; v < height_; ++v) {
      auto* row = vignette_.ptr<cv::Vec3f>(v);
      for (int u = 0; u < width_; ++u) {
        const double r2 = (u - cx) * (u - cx) + (v - cy) * (v - cy);
        row[u] = cv::Vec3f::all(static_cast<float>(1.0 - camera.vignetting * r2 / corner2));
      }
    }
  }
}

Renderer::~Renderer() = default;

void Renderer::renderPose(const Pose2& pose, bool antialias, bool sum_blocks, bool store,
                          float* acc, int v_begin, int v_end) {
  const Eigen::Vector3d origin = cameraInWorld(config_, pose).translation();
  tracer_->prepare(origin, pose.yaw_rad, view_.get());
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  const int W = width_ + 1;
  std::vector<Rgb>& color = corner_color_;
  std::vector<int>& id = corner_id_;
  color.resize(corner_dirs_.size());
  id.resize(corner_dirs_.size());
  traced_.resize(corner_dirs_.size());
  corner_plane_.resize(corner_dirs_.size());
  ++frame_;  // corners traced in this frame carry its number (no per-frame clearing)
  nearest_m_ = std::numeric_limits<double>::infinity();

  auto traceCorner = [&](size_t i) {
    if (traced_[i] == frame_) return;
    traced_[i] = frame_;
    if (!corner_valid_[i]) {
      id[i] = -1;
      return;
    }
    const Eigen::Vector3f& d = corner_dirs_[i];
    const Eigen::Vector3d dw(c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z());
    double distance;  // corner rays are unit vectors: t is the distance [m]
    // Where the ray meets its surface: for smoothCorners (marked floor) and for sampling edge
    // pixels on one plane (shadePixel).
    tracer_->trace(*view_, origin, dw, corner_bins_[i], &color[i], &id[i], &distance, &corner_plane_[i]);
    nearest_m_ = std::min(nearest_m_, distance);
  };

  const float thr = static_cast<float>(options_.edge_threshold);
  const float inv_samples = 1.0f / static_cast<float>(sample_offsets_.size());
  // A pixel's value: added to the image (blurred frames), or written into it (store: a still frame,
  // whose buffer then needs no clearing).
  const auto put = [store](float* out, float b, float g, float r) {
    if (store) {
      out[0] = b;
      out[1] = g;
      out[2] = r;
    } else {
      out[0] += b;
      out[1] += g;
      out[2] += r;
    }
  };
  // One pixel from its four (traced) corners: their mean where they agree, else the mean of
  // sample rays spread over the pixel's area.
  auto shadePixel = [&](int u, int v) {
    const size_t i00 = static_cast<size_t>(v * W + u), i10 = i00 + 1, i01 = i00 + W, i11 = i01 + 1;
    float* out = acc + 3 * (static_cast<size_t>(v) * width_ + u);
    if (id[i00] < 0 || id[i10] < 0 || id[i01] < 0 || id[i11] < 0) {
      if (store) out[0] = out[1] = out[2] = 0;  // outside the lens model: black
      return;
    }
    const Rgb &a = color[i00], &b = color[i10], &e = color[i01], &f = color[i11];
    const int id00 = id[i00] & ~kMarked;
    bool alike = id00 == (id[i10] & ~kMarked) && id00 == (id[i01] & ~kMarked) && id00 == (id[i11] & ~kMarked);
    if (alike) {
      const float rb_a = a.r + a.b, rb_b = b.r + b.b, rb_e = e.r + e.b, rb_f = f.r + f.b;
      alike = std::max(std::max(a.g, b.g), std::max(e.g, f.g)) - std::min(std::min(a.g, b.g), std::min(e.g, f.g)) <= thr &&
              std::max(std::max(rb_a, rb_b), std::max(rb_e, rb_f)) - std::min(std::min(rb_a, rb_b), std::min(rb_e, rb_f)) <= thr;
    }
    if (alike || !antialias || sample_offsets_.size() <= 1) {
      put(out, 0.25f * (a.b + b.b + e.b + f.b), 0.25f * (a.g + b.g + e.g + f.g),
          0.25f * (a.r + b.r + e.r + f.r));
      return;
    }
    // An edge crosses the pixel: integrate its area with samples spread over it.
    float sb = 0, sg = 0, sr = 0;
    const int surface = id[i00] & kSurfaceMask;
    if (options_.edge_samples_on_plane && surface != 0 && (id[i10] & kSurfaceMask) == surface &&
        (id[i01] & kSurfaceMask) == surface && (id[i11] & kSurfaceMask) == surface) {
      // All four corners on one plane (a board's squares, the floor's marks, a wall's posters):
      // the samples' points on it, interpolated between the corners' (a pixel's footprint is a
      // plane quad, its perspective within the pixel negligible), are coloured where they lie.
      const Eigen::Vector2f &p00 = corner_plane_[i00], &p10 = corner_plane_[i10];
      const Eigen::Vector2f &p01 = corner_plane_[i01], &p11 = corner_plane_[i11];
      for (const Eigen::Vector2f& t : sample_offsets_) {
        const Eigen::Vector2f l = p00 + (p01 - p00) * t.y(), r = p10 + (p11 - p10) * t.y();
        const Rgb col = tracer_->colorOn(surface, l + (r - l) * t.x(), origin);
        sb += col.b;
        sg += col.g;
        sr += col.r;
      }
      put(out, sb * inv_samples, sg * inv_samples, sr * inv_samples);
      return;
    }
    // Else sample rays, each interpolated between the pixel's corner rays (the lens mapping is
    // smooth within a pixel), traced through the scene.
    const Eigen::Vector3f &d00 = corner_dirs_[i00], &d10 = corner_dirs_[i10];
    const Eigen::Vector3f &d01 = corner_dirs_[i01], &d11 = corner_dirs_[i11];
    const uint16_t bin = corner_bins_[i00];
    for (const Eigen::Vector2f& t : sample_offsets_) {
      const Eigen::Vector3f l = d00 + (d01 - d00) * t.y(), r = d10 + (d11 - d10) * t.y();
      const Eigen::Vector3f d = l + (r - l) * t.x();
      const Eigen::Vector3d dw(c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z());
      Rgb col;
      int sample_id;
      tracer_->trace(*view_, origin, dw, bin, &col, &sample_id);
      sb += col.b;
      sg += col.g;
      sr += col.r;
    }
    put(out, sb * inv_samples, sg * inv_samples, sr * inv_samples);
  };

  if (width_ % 2 != 0 || height_ % 2 != 0) {
    for (size_t i = static_cast<size_t>(v_begin * W); i < static_cast<size_t>((v_end + 1) * W); ++i) {
      traceCorner(i);
    }
    for (int v = v_begin; v < v_end; ++v) {
      for (int u = 0; u < width_; ++u) shadePixel(u, v);
    }
    return;
  }
  // Coarse to fine. A block of pixels whose four outer corners lie on the same unmarked surface
  // (plain floor, sky, bare wall, a box face) with alike colours holds no edge: its pixels are the
  // bilinear blend of those corners (the mean of a pixel's corners is the blend at its centre).
  // Blocks of 4 x 4 pixels are tried first, then their 2 x 2 quarters; any other 2 x 2 block is
  // traced corner by corner and shaded per pixel.
  const auto smoothCorners = [&](size_t a, size_t b, size_t e, size_t f) {
    const int block_id = id[a];
    if (block_id < 0 || id[b] != block_id || id[e] != block_id || id[f] != block_id) return false;
    if (block_id & kMarked) {
      // Only the floor may still be blended: when no mark reaches into the block's footprint.
      if (block_id != (1 | kMarked)) return false;
      const Eigen::Vector2f &pa = corner_plane_[a], &pb = corner_plane_[b], &pe = corner_plane_[e],
                            &pf = corner_plane_[f];
      if (!tracer_->floorAreaHoldsNoMark(std::min(std::min(pa.x(), pb.x()), std::min(pe.x(), pf.x())),
                                        std::max(std::max(pa.x(), pb.x()), std::max(pe.x(), pf.x())),
                                        std::min(std::min(pa.y(), pb.y()), std::min(pe.y(), pf.y())),
                                        std::max(std::max(pa.y(), pb.y()), std::max(pe.y(), pf.y())))) {
        return false;
      }
    }
    const Rgb &ca = color[a], &cb = color[b], &ce = color[e], &cf = color[f];
    const float rb_a = ca.r + ca.b, rb_b = cb.r + cb.b, rb_e = ce.r + ce.b, rb_f = cf.r + cf.b;
    return std::max(std::max(ca.g, cb.g), std::max(ce.g, cf.g)) - std::min(std::min(ca.g, cb.g), std::min(ce.g, cf.g)) <= thr &&
           std::max(std::max(rb_a, rb_b), std::max(rb_e, rb_f)) - std::min(std::min(rb_a, rb_b), std::min(rb_e, rb_f)) <= thr;
  };
  // Fills an n x n block of pixels at (u, v) with the bilinear blend of its outer corners.
  const auto blend = [&](int u, int v, int n, size_t a, size_t b, size_t e, size_t f) {
    if (store) {
      blendBlock<true>(acc, width_, u, v, n, color[a], color[b], color[e], color[f]);
    } else {
      blendBlock<false>(acc, width_, u, v, n, color[a], color[b], color[e], color[f]);
    }
  };
  // A blurred frame's 4 x 4 blends: their corners' colours are summed over the poses and blended
  // once in render() (the blend is linear), not written into the image at every pose.
  const auto sumBlock4 = [&](int u, int v, const Rgb& ca, const Rgb& cb, const Rgb& ce,
                             const Rgb& cf) {
    const size_t k = static_cast<size_t>((v / 4) * (width_ / 4) + u / 4);
    Rgb* sum = &block_sums_[4 * k];
    const Rgb* corners[4] = {&ca, &cb, &ce, &cf};
    for (int c = 0; c < 4; ++c) {
      sum[c].b += corners[c]->b;
      sum[c].g += corners[c]->g;
      sum[c].r += corners[c]->r;
    }
    block_summed_[k] = 1;
  };
  const auto block2 = [&](int u, int v) {
    const size_t a = static_cast<size_t>(v * W + u), b = a + 2, e = a + 2 * W, f = e + 2;
    for (const size_t i : {a, b, e, f}) traceCorner(i);
    // The inner corners must be valid lens rays too.
    if (corner_valid_[a + 1] && corner_valid_[a + W] && corner_valid_[a + W + 1] && corner_valid_[a + W + 2] &&
        corner_valid_[e + 1] && smoothCorners(a, b, e, f)) {
      blend(u, v, 2, a, b, e, f);
      return;
    }
    for (const size_t i : {a + 1, a + W, a + W + 1, a + W + 2, e + 1}) traceCorner(i);
    shadePixel(u, v);
    shadePixel(u + 1, v);
    shadePixel(u, v + 1);
    shadePixel(u + 1, v + 1);
  };
  const bool by4 = width_ % 4 == 0 && height_ % 4 == 0;
  if (!by4) {
    for (int v = v_begin; v < v_end; v += 2) {
      for (int u = 0; u < width_; u += 2) block2(u, v);
    }
    return;
  }
  const int blocks_per_row = width_ / 4;
  const auto block4 = [&](int u, int v) {
    const size_t a = static_cast<size_t>(v * W + u), b = a + 4, e = a + 4 * W, f = e + 4;
    for (const size_t i : {a, b, e, f}) traceCorner(i);
    if (block4_valid_[static_cast<size_t>((v / 4) * blocks_per_row + u / 4)] &&
        smoothCorners(a, b, e, f)) {
      if (sum_blocks) {
        sumBlock4(u, v, color[a], color[b], color[e], color[f]);
      } else {
        blend(u, v, 4, a, b, e, f);
      }
      return;
    }
    block2(u, v);
    block2(u + 2, v);
    block2(u, v + 2);
    block2(u + 2, v + 2);
  };
  for (int v = v_begin; v < v_end; v += 4) {
    for (int u = 0; u < width_; u += 4) block4(u, v);
  }
}

cv::Mat Renderer::renderExact(const Pose2& pose) {
  cv::Mat acc(height_, width_, CV_32FC3);
  renderPose(pose, true, false, true, acc.ptr<float>(), 0, height_);
  return acc;
}

double Renderer::imageMotionBoundPx(const Pose2& a, const Pose2& b, double nearest_m) const {
  // A turn by dyaw about the vertical turns every ray by at most dyaw; a shift of the camera by
  // dc turns the ray to a point at distance >= nearest_m by at most dc / nearest_m.
  const double turn_rad = std::abs(std::remainder(b.yaw_rad - a.yaw_rad, 2 * M_PI));
  const double shift_m = (cameraInWorld(config_, b).translation() - cameraInWorld(config_, a).translation()).norm();
  if (shift_m == 0 && turn_rad == 0) return 0;
  return px_per_rad_ * (turn_rad + (nearest_m > 0 ? shift_m / nearest_m : std::numeric_limits<double>::infinity()));
}

const cv::Mat& Renderer::renderNoiseless(const std::vector<Pose2>& poses) {
  if (half_ && poses.size() > 1 && poses.size() >= static_cast<size_t>(options_.blur_half_res_poses)) {
    ++blurred_half_res_;
    // About one pose per pixel moved: at half resolution n / 2 + 1 of them, the first and the last
    // kept and none more than two apart, still put the poses within a pixel of each other.
    const size_t n = poses.size(), m = n / 2 + 1;
    std::vector<Pose2> spaced(m);
    for (size_t k = 0; k < m; ++k) spaced[k] = poses[(2 * k * (n - 1) + (m - 1)) / (2 * (m - 1))];
    cv::resize(half_->renderNoiseless(spaced), upscaled_, cv::Size(width_, height_), 0, 0,
               cv::INTER_LINEAR);
    return upscaled_;
  }
  // A still frame near the last one reuses its noiseless image (the noise below is fresh).
  const bool still = poses.size() == 1;
  const bool reuse = still && options_.still_reuse_px >= 0 && !still_image_.empty() &&
                     imageMotionBoundPx(still_pose_, poses[0], still_nearest_m_) <= options_.still_reuse_px;
  // Buffers are kept between frames: a fresh 640x480 float image costs page faults every frame.
  cv::Mat& acc = still && options_.still_reuse_px >= 0 ? still_image_ : accumulator_;
  if (reuse) {
    ++still_reused_;
  } else {
    acc.create(height_, width_, CV_32FC3);
    if (!still) acc.setTo(cv::Scalar::all(0));  // a still frame writes every pixel
    // A blurred frame sums its poses' 4 x 4 blends per block and blends each block once.
    const bool sum_blocks =
        options_.blur_block_sums && !still && width_ % 4 == 0 && height_ % 4 == 0;
    if (sum_blocks) {
      block_sums_.assign(static_cast<size_t>(4 * (width_ / 4) * (height_ / 4)), Rgb());
      block_summed_.assign(static_cast<size_t>((width_ / 4) * (height_ / 4)), 0);
    }
    for (const Pose2& p : poses) renderPose(p, still, sum_blocks, still, acc.ptr<float>(), 0, height_);
    if (sum_blocks) {
      for (int v = 0; v < height_; v += 4) {
        for (int u = 0; u < width_; u += 4) {
          const size_t k = static_cast<size_t>((v / 4) * (width_ / 4) + u / 4);
          if (!block_summed_[k]) continue;
          const Rgb* sum = &block_sums_[4 * k];
          blendBlock<false>(acc.ptr<float>(), width_, u, v, 4, sum[0], sum[1], sum[2], sum[3]);
        }
      }
    }
    if (poses.size() > 1) acc *= 1.0 / static_cast<double>(poses.size());
    if (still) {
      ++still_rendered_;
      still_pose_ = poses[0];
      still_nearest_m_ = nearest_m_;
    }
  }
  return acc;
}

int Renderer::rollingBandRows() const {
  // Bands of about 32 rows, a multiple of the 4 x 4 blocks (of 2 x 2 for sides not divisible by 4).
  const int step = width_ % 4 == 0 && height_ % 4 == 0 ? 4 : 2;
  return std::max(step, 32 / step * step);
}

cv::Mat Renderer::renderRolling(const std::vector<std::vector<Pose2>>& bands,
                                std::mt19937_64& rng) {
  const int band_rows = rollingBandRows();
  const int n_bands = (height_ + band_rows - 1) / band_rows;
  if (static_cast<int>(bands.size()) != n_bands) {
    throw InputError("renderer: a rolling-shutter frame needs " + std::to_string(n_bands) +
                     " bands of poses, got " + std::to_string(bands.size()));
  }
  // Each band of rows exposed at its own time: its poses' average, rendered over its rows only.
  accumulator_.create(height_, width_, CV_32FC3);
  accumulator_.setTo(cv::Scalar::all(0));
  for (int b = 0; b < n_bands; ++b) {
    const std::vector<Pose2>& poses = bands[static_cast<size_t>(b)];
    if (poses.empty()) throw InputError("renderer: no pose to render");
    const int v0 = b * band_rows, v1 = std::min(height_, v0 + band_rows);
    const bool still = poses.size() == 1;
    for (const Pose2& p : poses) renderPose(p, still, false, false, accumulator_.ptr<float>(), v0, v1);
    if (!still) accumulator_.rowRange(v0, v1) *= 1.0 / static_cast<double>(poses.size());
  }
  if (depthOfField()) traceDepths(bands.back().back());
  return finish(accumulator_, false, rng);
}

cv::Mat Renderer::render(const std::vector<Pose2>& poses, std::mt19937_64& rng) {
  if (poses.empty()) throw InputError("renderer: no pose to render");
  const uint64_t before = still_reused_;
  const cv::Mat& linear = renderNoiseless(poses);
  const bool reused = still_reused_ != before;
  if (depthOfField()) {
    // A reused still keeps its own distances (a blurred frame may have traced others since).
    if (reused && !still_depth_grid_.empty()) {
      still_depth_grid_.copyTo(depth_grid_);
    } else {
      traceDepths(poses.back());
      if (poses.size() == 1) depth_grid_.copyTo(still_depth_grid_);
    }
  }
  return finish(linear, reused, rng);
}

bool Renderer::depthOfField() const {
  return config_.focus_distance_m > 0 && config_.defocus_px_per_diopter > 0;
}

namespace {
constexpr int kDepthStep = 8;  ///< the depth grid's spacing [px]: the blur varies smoothly
}  // namespace

void Renderer::traceDepths(const Pose2& pose) {
  const Eigen::Vector3d origin = cameraInWorld(config_, pose).translation();
  tracer_->prepare(origin, pose.yaw_rad, view_.get());
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  const int cols = width_ / kDepthStep + 1, rows = height_ / kDepthStep + 1;
  depth_grid_.create(rows, cols, CV_32F);
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      const size_t k = static_cast<size_t>(j * kDepthStep * (width_ + 1) + i * kDepthStep);
      float& out = depth_grid_.at<float>(j, i);
      out = std::numeric_limits<float>::infinity();
      if (!corner_valid_[k]) continue;
      const Eigen::Vector3f& d = corner_dirs_[k];
      const Eigen::Vector3d dw(c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z());
      Rgb color;
      int id;
      double distance;
      tracer_->trace(*view_, origin, dw, corner_bins_[k], &color, &id, &distance);
      if (std::isfinite(distance) && distance > 0) out = static_cast<float>(distance);
    }
  }
}

const cv::Mat& Renderer::defocus(const cv::Mat& linear, bool same_scene) {
  // A reused still with the ring where it was: the blur of the last frame.
  if (same_scene && defocused_valid_ && defocused_for_px_ == defocus_px_ &&
      defocused_from_ == linear.data) {
    return defocused_;
  }
  defocused_valid_ = false;
  if (!depthOfField()) {
    if (defocus_px_ == 0) return linear;
    cv::GaussianBlur(linear, defocused_, cv::Size(), std::abs(defocus_px_));
    defocused_valid_ = true, defocused_for_px_ = defocus_px_, defocused_from_ = linear.data;
    return defocused_;
  }
  // Each point's blur from its distance in dioptres off the focus, plus the ring's.
  cv::Mat sigma(depth_grid_.size(), CV_32F);
  double max_sigma = 0;
  const double focus_diopters = 1.0 / config_.focus_distance_m;
  for (int j = 0; j < sigma.rows; ++j) {
    for (int i = 0; i < sigma.cols; ++i) {
      const float d = depth_grid_.at<float>(j, i);
      const double diopters = std::isfinite(d) ? 1.0 / d : 0.0;
      const double px =
          std::abs(defocus_px_ + config_.defocus_px_per_diopter * (diopters - focus_diopters));
      sigma.at<float>(j, i) = static_cast<float>(px);
      max_sigma = std::max(max_sigma, px);
    }
  }
  if (max_sigma < 0.2) return linear;
  cv::resize(sigma, sigma_map_, linear.size(), 0, 0, cv::INTER_LINEAR);
  // Blurred levels half a pixel of sigma apart; each pixel between the two around its own sigma.
  const int n = std::min(12, 1 + static_cast<int>(std::ceil(max_sigma / 0.5)));
  levels_.resize(static_cast<size_t>(n));
  levels_[0] = linear;
  for (int k = 1; k < n; ++k) {
    cv::GaussianBlur(linear, levels_[static_cast<size_t>(k)], cv::Size(), max_sigma * k / (n - 1));
  }
  defocused_.create(linear.size(), CV_32FC3);
  for (int v = 0; v < linear.rows; ++v) {
    const float* sig = sigma_map_.ptr<float>(v);
    auto* out = defocused_.ptr<cv::Vec3f>(v);
    for (int u = 0; u < linear.cols; ++u) {
      const double t = std::clamp(sig[u] / max_sigma, 0.0, 1.0) * (n - 1);
      const int lo = std::min(n - 2, static_cast<int>(t));
      const float f = static_cast<float>(t - lo);
      const cv::Vec3f& a = levels_[static_cast<size_t>(lo)].at<cv::Vec3f>(v, u);
      const cv::Vec3f& b = levels_[static_cast<size_t>(lo + 1)].at<cv::Vec3f>(v, u);
      out[u] = a + (b - a) * f;
    }
  }
  defocused_valid_ = true, defocused_for_px_ = defocus_px_, defocused_from_ = linear.data;
  return defocused_;
}

cv::Mat Renderer::finish(const cv::Mat& linear, bool same_scene, std::mt19937_64& rng) {
  // The lens out of focus blurs the light before the sensor adds its noise.
  const cv::Mat& acc = defocus(linear, same_scene);
  // The frame's brightness (auto-exposure and light that vary), drawn only when it varies.
  double gain = 1.0;
  if (config_.brightness_sigma > 0) {
    gain = std::clamp(1.0 + std::normal_distribution<double>(0.0, config_.brightness_sigma)(rng),
                      0.2, 3.0);
  }
  const bool shaded = gain != 1.0 || !vignette_.empty();
  cv::Mat out(height_, width_, CV_8UC3);
  if (noise_table_.empty() && !shaded) {
    acc.convertTo(out, CV_8UC3);
    return out;
  }
  size_t offset = 0;
  if (!noise_table_.empty()) {
    const size_t n = static_cast<size_t>(width_) * height_ * 3;
    offset = std::uniform_int_distribution<size_t>(0, noise_table_.size() - n)(rng);
  }
  // Shaded, noise added, then rounded and saturated to 0..255, row by row through one-row buffers
  // that stay in the cache (an image-sized float buffer in between cost memory traffic: a large
  // part of a frame's time is moving image-sized buffers).
  for (int v = 0; v < height_; ++v) {
    cv::Mat row = acc.row(v);
    if (shaded) {
      if (vignette_.empty()) {
        row.convertTo(shaded_row_, CV_32FC3, gain);
      } else {
        cv::multiply(row, vignette_.row(v), shaded_row_, gain);
      }
      row = shaded_row_;
    }
    if (!noise_table_.empty()) {
      const cv::Mat noise(1, width_, CV_32FC3,
                          const_cast<float*>(noise_table_.data() + offset + static_cast<size_t>(v) * width_ * 3));
      cv::scaleAdd(noise, options_.noise_sigma, row, noisy_row_);
      row = noisy_row_;
    }
    row.convertTo(out.row(v), CV_8UC3);  // rounds and saturates to 0..255
  }
  return out;
}

cv::Mat renderFrame(Renderer& renderer, const Simulation& simulation, double capture_s,
                    int max_blur_samples, std::mt19937_64& rng) {
  if (simulation.robot().camera.readout_s <= 0) {
    return renderer.render(simulation.exposurePoses(capture_s, max_blur_samples), rng);
  }
  const auto bands =
      simulation.rollingExposurePoses(capture_s, max_blur_samples, renderer.rollingBandRows());
  const Pose2& first = bands[0][0];
  const bool still = std::all_of(bands.begin(), bands.end(), [&](const std::vector<Pose2>& b) {
    return b.size() == 1 && b[0].x_m == first.x_m && b[0].y_m == first.y_m &&
           b[0].yaw_rad == first.yaw_rad;
  });
  return still ? renderer.render(bands[0], rng) : renderer.renderRolling(bands, rng);
}

}  // namespace sim
}  // namespace autocal
