// The simulator's ray tracer: the world of a WorldConfig as surfaces a ray can hit (the floor
// with its tags, floor boards and lane lines; boards on stands, textured walls, boxes), and the
// colour and surface id of the first surface a ray meets. The Renderer traces the rays of its
// pixel corners and edge samples through it. Private to the simulator's core (sim/src).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"

namespace autocal {
namespace sim {
namespace tracing {

constexpr int kAzimuthBins = 1024;
constexpr int kBinPadding = 2;
constexpr uint16_t kAllBins = kAzimuthBins;  // rays too close to vertical to have an azimuth
// Flag of a surface id: the surface carries sharp marks (floor tags and lines) that may be
// smaller than a block of pixels, so it is never interpolated. (Boards need no flag: each square
// and margin strip has an id of its own, see boardColor.)
constexpr int kMarked = 1 << 30;
// The bits of a surface id that name the plane it lies on (0: the sky, 1: the floor, else a
// vertical quad's or a box top's id); the bits above name the part (a board's square, a poster).
constexpr int kSurfaceMask = 0xFFFF;

using detail::Rgb;

using detail::Rgb;

inline Rgb rgb(double r, double g, double b) {
  return {static_cast<float>(b), static_cast<float>(g), static_cast<float>(r)};
}
inline Rgb rgb(const std::vector<double>& c) { return rgb(c[0], c[1], c[2]); }
inline Rgb scaled(const Rgb& c, float k) { return {c.b * k, c.g * k, c.r * k}; }

inline const Rgb kSky = rgb(205, 205, 215);
inline const Rgb kPaperWhite = rgb(228, 228, 225);
inline const Rgb kPrintBlack = rgb(28, 28, 30);
inline const Rgb kBoardBack = rgb(125, 105, 80);
inline const Rgb kStand = rgb(70, 70, 72);
inline const Rgb kLaneWhite = rgb(232, 232, 232);
inline const Rgb kLaneYellow = rgb(235, 200, 40);

/// The azimuth bin (0 .. kAzimuthBins - 1) of a direction in the robot frame.
int azimuthBin(double azimuth_rad);

enum class Surface : uint8_t { kBoard, kBoardBack, kStand, kWall, kBox };

/// A vertical rectangle standing on the segment p0 -> p1 between heights z0 and z1.
struct VerticalQuad {
  Eigen::Vector2d p0, dir;  // dir: unit vector p0 -> p1
  double length = 0, z0 = 0, z1 = 0;
  Eigen::Vector2d front;  // normal of the front side (boards: the printed side)
  Surface front_surface = Surface::kBox, back_surface = Surface::kBox;
  int index = 0;  // board or wall index
  Rgb color;
  int id = 0;
};

/// A horizontal rectangle (the top of a box) at height z.
struct HorizontalRect {
  Eigen::Vector2d c, u;  // centre, unit axis
  double hu = 0, hv = 0, z = 0;
  Rgb color;
  int id = 0;
};

/// A mark painted on the floor: an AprilTag or a stretch of lane line.
struct FloorFeature {
  bool is_tag = false;
  Eigen::Vector2d c, u;  // centre, unit axis (tag: its x axis; line: along the line)
  double hu = 0, hv = 0;  // half extents along u and along its left normal
  std::vector<uint8_t> bitmap;  // tag: total_width^2 cells, row-major, 0 = black
  int cells = 0;                // bitmap columns (along u); tag: total_width
  int cells_v = 0;              // bitmap rows (against u's left normal)
  double cell = 0;              // tag: cell edge [m]
  double dash = 0, period = 0;  // line: dash length and dash + gap (0: solid)
  Rgb color;
};

/// A wall's procedural texture, baked into a texel map (kWallTexel_m per texel) and sampled
/// bilinearly; posters are drawn on top with sharp edges.
constexpr double kWallTexel_m = 0.01;
struct WallTexture {
  Rgb base;
  uint32_t seed = 0;
  struct Poster {
    double s0, s1, z0, z1;
    Rgb color;
    bool striped;
  };
  std::vector<Poster> posters;
  int nx = 0, nz = 0;
  std::vector<float> shade;  // brightness factor per texel

  float sampleShade(double s, double z) const {
    const double x = std::clamp(s / kWallTexel_m, 0.0, nx - 1.001);
    const double y = std::clamp(z / kWallTexel_m, 0.0, nz - 1.001);
    const int ix = static_cast<int>(x), iy = static_cast<int>(y);
    const float tx = static_cast<float>(x - ix), ty = static_cast<float>(y - iy);
    const float* row0 = &shade[static_cast<size_t>(iy * nx + ix)];
    const float* row1 = row0 + nx;
    return (row0[0] + (row0[1] - row0[0]) * tx) * (1 - ty) + (row1[0] + (row1[1] - row1[0]) * tx) * ty;
  }
};

/// What the tracer keeps per camera position (RayTracer::prepare fills it): the vertical quads each
/// azimuth bin must test, the nearest of them per bin, and the box tops seen from above. The
/// caller owns it, so that tracing itself changes nothing.
struct TraceView {
  std::vector<std::vector<int>> bins;
  std::vector<double> bin_min_dist2;  ///< squared floor-plan distance to the bin's nearest quad
  std::vector<int> visible_tops;
};

class RayTracer {

 public:
  explicit RayTracer(const WorldConfig& world);

  /// Colour and surface id of the first surface hit by the ray o + t d (t > 0); d need not be
  /// unit. bin: the azimuth bin of d in the robot frame (kAllBins: test every vertical quad).
  /// *distance (when given): the ray parameter t of the hit (+inf for the sky); with a unit d, the
  /// distance [m] to the surface.
  /// *plane (when given): where on its surface the ray hit, the coordinates colorOn takes.
  inline void trace(const TraceView& view, const Eigen::Vector3d& o, const Eigen::Vector3d& d, uint16_t bin, Rgb* color,
                    int* id, double* distance = nullptr, Eigen::Vector2f* plane = nullptr) const;

  /// The colour a ray traced from `o` finds on the surface `surface` (a hit's id & kSurfaceMask:
  /// the floor, a vertical quad or a box top) at plane coordinates `at` (as trace gives them: the
  /// floor's x, y; a quad's s, z). An edge pixel whose corners all lie on one such plane is
  /// sampled here, at points interpolated between its corners' plane coordinates, instead of by
  /// tracing each sample ray through the scene.
  inline Rgb colorOn(int surface, const Eigen::Vector2f& at, const Eigen::Vector3d& o) const;

  /// True when no floor mark (tag, lane line) reaches into the rectangle [x0, x1] x [y0, y1]. A
  /// block of pixels on the floor maps to a convex quad of the floor plane: when the quad's
  /// bounding box holds no mark, the block holds no edge even where the floor grid is marked.
  bool floorAreaHoldsNoMark(double x0, double x1, double y0, double y1) const;

  /// Fills `view` for a camera at `origin` on a robot of this yaw: which vertical quads each
  /// azimuth bin must test, and which box tops the camera sees.
  void prepare(const Eigen::Vector3d& origin, double yaw_rad, TraceView* view) const;

 private:
  /// Floor colour at (x, y); *marked: the point lies in a grid cell that holds marks.
  inline Rgb floorColor(double x, double y, bool* marked) const;
  /// Colour of a board at (s, z); *cell numbers the convex region it lies in (a square, or a strip
  /// or corner of the white margin), so that equal cells at a block's corners mean no edge inside.
  inline Rgb boardColor(const VerticalQuad& q, double s, double z, int* cell) const;
  /// Wall colour at (s, z); *part tells the posters (1 + index) from the bare wall (0).
  inline Rgb wallColor(const VerticalQuad& q, double s, double z, int* part) const;
  /// Colour of this side of a quad at (s, z); *part: the board's cell or the wall's poster (0: none).
  inline Rgb quadColor(const VerticalQuad& q, Surface surface, double s, double z, int* part) const;
  /// `c` in the room's light at the world point (x, y).
  inline Rgb lit(const Rgb& c, double x, double y) const {
    return world_.light_gradient.even() ? c : scaled(c, static_cast<float>(world_.light_gradient.at(x, y)));
  }

  WorldConfig world_;
  Rgb floor_color_;
  std::vector<VerticalQuad> quads_;
  std::vector<HorizontalRect> tops_;
  std::vector<FloorFeature> features_;
  std::vector<std::array<double, 4>> feature_boxes_;  // x0, x1, y0, y1 of each feature
  std::vector<WallTexture> wall_textures_;
  // Floor feature grid.
  double grid_x0_ = 0, grid_y0_ = 0, grid_cell_ = 0.25, inv_grid_cell_ = 4.0;
  int grid_nx_ = 0, grid_ny_ = 0;
  std::vector<std::vector<int>> grid_;
  std::vector<int> quad_of_id_;  // surface id -> index into quads_ (-1: not a quad)
  std::vector<int> top_of_id_;   // surface id -> index into tops_ (-1: not a box top)
};

// The hot path, inline: the renderer calls trace() for every pixel corner and edge sample.

inline Rgb RayTracer::floorColor(double x, double y, bool* marked) const {
  *marked = false;
  if (!grid_.empty()) {
    const double gx = (x - grid_x0_) * inv_grid_cell_, gy = (y - grid_y0_) * inv_grid_cell_;
    const int ix = static_cast<int>(gx), iy = static_cast<int>(gy);
    if (gx >= 0 && gy >= 0 && ix < grid_nx_ && iy < grid_ny_) {
      const std::vector<int>& cell = grid_[iy * grid_nx_ + ix];
      *marked = !cell.empty();
      for (int i : cell) {
        const FloorFeature& f = features_[i];
        const double dx = x - f.c.x(), dy = y - f.c.y();
        const double a = dx * f.u.x() + dy * f.u.y();   // along u
        const double b = -dx * f.u.y() + dy * f.u.x();  // along u turned left
        if (std::abs(a) > f.hu || std::abs(b) > f.hv) continue;
        if (!f.is_tag) return f.color;
        // Bitmap column grows along the tag's x (u), its row grows against the tag's up (b).
        const int col = static_cast<int>(std::floor(a / f.cell + 0.5 * f.cells));
        const int row = static_cast<int>(std::floor(-b / f.cell + 0.5 * f.cells_v));
        if (col < 0 || row < 0 || col >= f.cells || row >= f.cells_v) continue;
        return f.bitmap[row * f.cells + col] ? kPaperWhite : kPrintBlack;
      }
    }
  }
  return floor_color_;
}

inline Rgb RayTracer::boardColor(const VerticalQuad& q, double s, double z, int* cell) const {
  const ChessboardConfig& b = world_.chessboards[q.index];
  const double u = (s - b.margin_m) / b.square_m;
  const double v = (q.z1 - b.margin_m - z) / b.square_m;
  // Squares are cells 0..cols by 0..rows (cols + 1 by rows + 1 squares); the margin is split into
  // the convex strips beside each row and column and the four corners (cell -1 or cols + 1).
  const int a = std::clamp(static_cast<int>(std::floor(u)), -1, b.cols + 1);
  const int c = std::clamp(static_cast<int>(std::floor(v)), -1, b.rows + 1);
  *cell = 1 + (a + 1) + (c + 1) * (b.cols + 3);
  if (a < 0 || c < 0 || a > b.cols || c > b.rows) return kPaperWhite;
  return ((a + c) % 2 == 0) ? kPrintBlack : kPaperWhite;
}

inline Rgb RayTracer::wallColor(const VerticalQuad& q, double s, double z, int* part) const {
  const WallTexture& t = wall_textures_[q.index];
  *part = 0;
  for (const auto& p : t.posters) {
    ++*part;
    if (s >= p.s0 && s <= p.s1 && z >= p.z0 && z <= p.z1) {
      if (p.striped && static_cast<int>(std::floor((s - p.s0) / 0.03)) % 2 == 0) {
        return scaled(p.color, 0.55f);
      }
      return p.color;
    }
  }
  *part = 0;
  return scaled(t.base, t.sampleShade(s, z));
}

inline void RayTracer::trace(const TraceView& view, const Eigen::Vector3d& o, const Eigen::Vector3d& d, uint16_t bin,
                         Rgb* color, int* id, double* distance, Eigen::Vector2f* plane) const {
  double best = std::numeric_limits<double>::infinity();
  int hit = -1;  // -1 nothing, -2 floor, -3 - k: top k, >= 0: quad
  double hit_s = 0;
  bool quads_possible = true;
  if (d.z() < 0) {
    best = -o.z() / d.z();
    hit = -2;
    quads_possible = best * best * (d.x() * d.x() + d.y() * d.y()) >= view.bin_min_dist2[bin];
  }
  if (quads_possible) for (int i : view.bins[bin]) {
    const VerticalQuad& q = quads_[i];
    // Solve o2 + t d2 = p0 + s dir in the floor plan.
    const double denom = d.x() * q.dir.y() - d.y() * q.dir.x();
    if (std::abs(denom) < 1e-14) continue;
    const double wx = q.p0.x() - o.x(), wy = q.p0.y() - o.y();
    const double t = (wx * q.dir.y() - wy * q.dir.x()) / denom;
    if (t <= 0 || t >= best) continue;
    const double s = (wx * d.y() - wy * d.x()) / denom;
    if (s < 0 || s > q.length) continue;
    const double z = o.z() + t * d.z();
    if (z < q.z0 || z > q.z1) continue;
    best = t;
    hit = i;
    hit_s = s;
  }
  for (int k : view.visible_tops) {
    const HorizontalRect& r = tops_[static_cast<size_t>(k)];
    if (d.z() >= 0) continue;
    const double t = (r.z - o.z()) / d.z();
    if (t <= 0 || t >= best) continue;
    const double dx = o.x() + t * d.x() - r.c.x(), dy = o.y() + t * d.y() - r.c.y();
    if (std::abs(dx * r.u.x() + dy * r.u.y()) > r.hu) continue;
    if (std::abs(-dx * r.u.y() + dy * r.u.x()) > r.hv) continue;
    best = t;
    hit = -3 - static_cast<int>(k);
  }
  if (distance) *distance = best;
  if (hit == -1) {
    *color = kSky;
    *id = 0;
  } else if (hit == -2) {
    bool marked = false;
    const double x = o.x() + best * d.x(), y = o.y() + best * d.y();
    *color = lit(floorColor(x, y, &marked), x, y);
    *id = marked ? (1 | kMarked) : 1;
    if (plane) *plane = Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y));
  } else if (hit <= -3) {
    const HorizontalRect& r = tops_[static_cast<size_t>(-3 - hit)];
    *color = lit(r.color, o.x() + best * d.x(), o.y() + best * d.y());
    *id = r.id;
    if (plane) {
      *plane = Eigen::Vector2f(static_cast<float>(o.x() + best * d.x()), static_cast<float>(o.y() + best * d.y()));
    }
  } else {
    const VerticalQuad& q = quads_[static_cast<size_t>(hit)];
    const bool front = d.x() * q.front.x() + d.y() * q.front.y() < 0;
    const Surface surface = front ? q.front_surface : q.back_surface;
    const double z = o.z() + best * d.z();
    if (plane) *plane = Eigen::Vector2f(static_cast<float>(hit_s), static_cast<float>(z));
    int part = 0;
    const Eigen::Vector2d at = q.p0 + hit_s * q.dir;
    *color = lit(quadColor(q, surface, hit_s, z, &part), at.x(), at.y());
    *id = q.id + (part << 16);
  }
}

inline Rgb RayTracer::quadColor(const VerticalQuad& q, Surface surface, double s, double z, int* part) const {
  *part = 0;
  switch (surface) {
    case Surface::kBoard:
      // Each square and margin region is a surface of its own: a block whose corners share one
      // cannot hold an edge (the regions are convex), so it may be blended like plain surfaces.
      return boardColor(q, s, z, part);
    case Surface::kBoardBack:
      return kBoardBack;
    case Surface::kWall:
      return wallColor(q, s, z, part);  // posters are surfaces of their own: their edges are edges
    case Surface::kStand:
    case Surface::kBox:
      break;
  }
  return q.color;
}

inline Rgb RayTracer::colorOn(int surface, const Eigen::Vector2f& at, const Eigen::Vector3d& o) const {
  if (surface == 1) {
    bool marked = false;
    return lit(floorColor(at.x(), at.y(), &marked), at.x(), at.y());
  }
  const int top = top_of_id_[static_cast<size_t>(surface)];
  if (top >= 0) return lit(tops_[static_cast<size_t>(top)].color, at.x(), at.y());
  const VerticalQuad& q = quads_[static_cast<size_t>(quad_of_id_[static_cast<size_t>(surface)])];
  // The camera sees the quad's front when it stands on the side its front normal points to.
  const bool front = (o.x() - q.p0.x()) * q.front.x() + (o.y() - q.p0.y()) * q.front.y() > 0;
  int part = 0;
  const Eigen::Vector2d p = q.p0 + static_cast<double>(at.x()) * q.dir;
  return lit(quadColor(q, front ? q.front_surface : q.back_surface, at.x(), at.y(), &part), p.x(),
             p.y());
}

}  // namespace tracing
}  // namespace sim
}  // namespace autocal
