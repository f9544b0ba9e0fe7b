#include "autocal/sim/renderer.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/sim/scene.h"

namespace autocal {
namespace sim {

namespace {

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

Rgb rgb(double r, double g, double b) {
  return {static_cast<float>(b), static_cast<float>(g), static_cast<float>(r)};
}
Rgb rgb(const std::vector<double>& c) { return rgb(c[0], c[1], c[2]); }
Rgb scaled(const Rgb& c, float k) { return {c.b * k, c.g * k, c.r * k}; }

const Rgb kSky = rgb(205, 205, 215);
const Rgb kPaperWhite = rgb(228, 228, 225);
const Rgb kPrintBlack = rgb(28, 28, 30);
const Rgb kBoardBack = rgb(125, 105, 80);
const Rgb kStand = rgb(70, 70, 72);
const Rgb kLaneWhite = rgb(232, 232, 232);
const Rgb kLaneYellow = rgb(235, 200, 40);

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

uint32_t hash3(uint32_t a, int32_t x, int32_t y) {
  uint32_t h = a * 0x9E3779B1u ^ static_cast<uint32_t>(x) * 0x85EBCA77u ^
               static_cast<uint32_t>(y) * 0xC2B2AE3Du;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}
float unit(uint32_t h) { return static_cast<float>(h & 0xFFFFFF) / 16777216.0f; }

/// Smooth value noise in [0, 1): bilinear interpolation of hashed lattice values.
float valueNoise(uint32_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3 - 2 * tx);
  ty = ty * ty * (3 - 2 * ty);
  const float a = unit(hash3(seed, ix, iy)), b = unit(hash3(seed, ix + 1, iy));
  const float c = unit(hash3(seed, ix, iy + 1)), d = unit(hash3(seed, ix + 1, iy + 1));
  return static_cast<float>((a + (b - a) * tx) * (1 - ty) + (c + (d - c) * tx) * ty);
}

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

}  // namespace

class Scene {
 public:
  Scene(const WorldConfig& world);

  /// Colour and surface id of the first surface hit by the ray o + t d (t > 0); d need not be
  /// unit. bin: the azimuth bin of d in the robot frame (kAllBins: test every vertical quad).
  /// *distance (when given): the ray parameter t of the hit (+inf for the sky); with a unit d, the
  /// distance [m] to the surface.
  /// *plane (when given): where on its surface the ray hit, the coordinates colorOn takes.
  inline void trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d, uint16_t bin, Rgb* color,
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

  /// Prepares the per-bin lists of vertical quads for a camera at `origin` on a robot of this yaw.
  void prepare(const Eigen::Vector3d& origin, double yaw_rad) const;

 private:
  /// Floor colour at (x, y); *marked: the point lies in a grid cell that holds marks.
  Rgb floorColor(double x, double y, bool* marked) const;
  /// Colour of a board at (s, z); *cell numbers the convex region it lies in (a square, or a strip
  /// or corner of the white margin), so that equal cells at a block's corners mean no edge inside.
  Rgb boardColor(const VerticalQuad& q, double s, double z, int* cell) const;
  /// Wall colour at (s, z); *part tells the posters (1 + index) from the bare wall (0).
  Rgb wallColor(const VerticalQuad& q, double s, double z, int* part) const;
  /// Colour of this side of a quad at (s, z); *part: the board's cell or the wall's poster (0: none).
  inline Rgb quadColor(const VerticalQuad& q, Surface surface, double s, double z, int* part) const;

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
  // Per-frame azimuth bins and visible box tops (mutable: prepared per rendered pose).
  mutable std::vector<std::vector<int>> bins_;
  mutable std::vector<double> bin_min_dist2_;  // squared floor-plan distance to the nearest quad
  mutable std::vector<int> visible_tops_;
  std::vector<int> quad_of_id_;  // surface id -> index into quads_ (-1: not a quad)
  std::vector<int> top_of_id_;   // surface id -> index into tops_ (-1: not a box top)
};

Scene::Scene(const WorldConfig& world) : world_(world), floor_color_(rgb(world.floor_color)) {
  int next_id = 2;  // 0: nothing, 1: floor
  for (size_t i = 0; i < world.chessboards.size(); ++i) {
    const ChessboardConfig& b = world.chessboards[i];
    const Eigen::Vector2d right = boardRight(b), centre(b.pose.x_m, b.pose.y_m);
    VerticalQuad q;
    q.p0 = centre - 0.5 * boardWidth(b) * right;
    q.dir = right;
    q.length = boardWidth(b);
    q.z0 = b.center_z_m - 0.5 * boardHeight(b);
    q.z1 = b.center_z_m + 0.5 * boardHeight(b);
    q.front = boardNormal(b);
    q.front_surface = Surface::kBoard;
    q.back_surface = Surface::kBoardBack;
    q.index = static_cast<int>(i);
    q.id = next_id++;
    quads_.push_back(q);
    // The stand: a post under the board's centre.
    VerticalQuad s = q;
    const double post = 0.03;
    s.p0 = centre - 0.5 * post * right;
    s.length = post;
    s.z0 = 0;
    s.z1 = q.z0;
    s.front_surface = s.back_surface = Surface::kStand;
    s.color = kStand;
    s.id = next_id++;
    if (s.z1 > 1e-4) quads_.push_back(s);
  }
  for (size_t i = 0; i < world.walls.size(); ++i) {
    const WallConfig& w = world.walls[i];
    VerticalQuad q;
    q.p0 = Eigen::Vector2d(w.x0_m, w.y0_m);
    const Eigen::Vector2d p1(w.x1_m, w.y1_m);
    q.length = (p1 - q.p0).norm();
    q.dir = (p1 - q.p0) / q.length;
    q.z0 = 0;
    q.z1 = w.height_m;
    q.front = Eigen::Vector2d(-q.dir.y(), q.dir.x());
    q.front_surface = q.back_surface = Surface::kWall;
    q.index = static_cast<int>(i);
    q.id = next_id++;
    quads_.push_back(q);
    // A procedural texture: smooth mottling plus a few posters, different for every seed, so that
    // no two stretches of wall look alike.
    WallTexture tex;
    tex.seed = w.texture_seed;
    const uint32_t s = w.texture_seed;
    tex.base = rgb(120 + 90 * unit(hash3(s, 1, 0)), 120 + 90 * unit(hash3(s, 2, 0)),
                   120 + 90 * unit(hash3(s, 3, 0)));
    const int posters = 3 + static_cast<int>(q.length / 0.6);
    for (int k = 0; k < posters; ++k) {
      WallTexture::Poster p;
      const double w_m = 0.12 + 0.25 * unit(hash3(s, k, 10));
      const double h_m = 0.08 + 0.2 * unit(hash3(s, k, 11));
      p.s0 = unit(hash3(s, k, 12)) * std::max(0.0, q.length - w_m);
      p.s1 = p.s0 + w_m;
      p.z0 = 0.05 + unit(hash3(s, k, 13)) * std::max(0.0, w.height_m - h_m - 0.1);
      p.z1 = p.z0 + h_m;
      p.color = rgb(40 + 200 * unit(hash3(s, k, 14)), 40 + 200 * unit(hash3(s, k, 15)),
                    40 + 200 * unit(hash3(s, k, 16)));
      p.striped = (hash3(s, k, 17) & 1u) != 0;
      tex.posters.push_back(p);
    }
    tex.nx = static_cast<int>(std::ceil(q.length / kWallTexel_m)) + 2;
    tex.nz = static_cast<int>(std::ceil(w.height_m / kWallTexel_m)) + 2;
    tex.shade.resize(static_cast<size_t>(tex.nx * tex.nz));
    for (int iz = 0; iz < tex.nz; ++iz) {
      for (int ix = 0; ix < tex.nx; ++ix) {
        const double ss = ix * kWallTexel_m, zz = iz * kWallTexel_m;
        tex.shade[static_cast<size_t>(iz * tex.nx + ix)] =
            0.7f + 0.22f * valueNoise(s, ss / 0.15, zz / 0.15) + 0.08f * valueNoise(s + 7, ss / 0.04, zz / 0.04);
      }
    }
    wall_textures_.push_back(std::move(tex));
  }
  for (const ObstacleConfig& o : world.obstacles) {
    const Eigen::Vector2d c(o.pose.x_m, o.pose.y_m);
    const Eigen::Vector2d u(std::cos(o.pose.yaw_rad), std::sin(o.pose.yaw_rad));
    const Eigen::Vector2d v(-u.y(), u.x());
    const Eigen::Vector2d corners[4] = {c - 0.5 * o.length_m * u - 0.5 * o.width_m * v,
                                        c + 0.5 * o.length_m * u - 0.5 * o.width_m * v,
                                        c + 0.5 * o.length_m * u + 0.5 * o.width_m * v,
                                        c - 0.5 * o.length_m * u + 0.5 * o.width_m * v};
    const float shade[4] = {0.8f, 1.0f, 0.65f, 0.9f};  // faces differ so that edges show
    for (int k = 0; k < 4; ++k) {
      VerticalQuad q;
      q.p0 = corners[k];
      const Eigen::Vector2d p1 = corners[(k + 1) % 4];
      q.length = (p1 - q.p0).norm();
      q.dir = (p1 - q.p0) / q.length;
      q.z0 = 0;
      q.z1 = o.height_m;
      q.front = Eigen::Vector2d(q.dir.y(), -q.dir.x());  // counter-clockwise corners: outwards
      q.front_surface = q.back_surface = Surface::kBox;
      q.color = scaled(rgb(o.color), shade[k]);
      q.id = next_id++;
      quads_.push_back(q);
    }
    HorizontalRect top;
    top.c = c;
    top.u = u;
    top.hu = 0.5 * o.length_m;
    top.hv = 0.5 * o.width_m;
    top.z = o.height_m;
    top.color = scaled(rgb(o.color), 1.1f);
    top.id = next_id++;
    tops_.push_back(top);
  }

  // Floor marks: tags drawn from the family's own code bits (libapriltag renders the code into
  // its total_width x total_width cell image), and lane lines (split into dashes).
  apriltag_family_t* family = tag36h11_create();
  for (const FloorTagConfig& t : world.floor_tags) {
    FloorFeature f;
    f.is_tag = true;
    f.c = Eigen::Vector2d(t.pose.x_m, t.pose.y_m);
    f.u = Eigen::Vector2d(std::cos(t.pose.yaw_rad), std::sin(t.pose.yaw_rad));
    image_u8_t* im = apriltag_to_image(family, t.id);
    f.cells = im->width;
    f.bitmap.resize(static_cast<size_t>(im->width * im->height));
    for (int y = 0; y < im->height; ++y) {
      for (int x = 0; x < im->width; ++x) f.bitmap[y * im->width + x] = im->buf[y * im->stride + x];
    }
    std::free(im->buf);
    std::free(im);
    f.cells_v = f.cells;
    f.cell = t.size_m / family->width_at_border;
    f.hu = f.hv = 0.5 * f.cell * f.cells;
    features_.push_back(std::move(f));
  }
  tag36h11_destroy(family);
  // Chessboards on the floor: their squares as a bitmap (rows of squares counting along the
  // board's yaw, columns to its left), then their white margin behind them.
  for (const FloorBoardConfig& b : world.floor_boards) {
    FloorFeature f;
    f.is_tag = true;
    f.c = Eigen::Vector2d(b.pose.x_m, b.pose.y_m);
    const Eigen::Vector2d along(std::cos(b.pose.yaw_rad), std::sin(b.pose.yaw_rad));
    f.u = Eigen::Vector2d(-along.y(), along.x());  // columns run to the left
    f.cells = b.cols + 1;
    f.cells_v = b.rows + 1;
    f.cell = b.square_m;
    f.hu = 0.5 * f.cell * f.cells;
    f.hv = 0.5 * f.cell * f.cells_v;
    f.bitmap.resize(static_cast<size_t>(f.cells * f.cells_v));
    for (int r = 0; r < f.cells_v; ++r) {
      for (int c = 0; c < f.cells; ++c) f.bitmap[r * f.cells + c] = (r + c) % 2 ? 255 : 0;
    }
    FloorFeature margin;
    margin.c = f.c;
    margin.u = f.u;
    margin.hu = f.hu + b.margin_m;
    margin.hv = f.hv + b.margin_m;
    margin.color = kPaperWhite;
    features_.push_back(std::move(f));
    features_.push_back(std::move(margin));
  }
  for (const LaneLineConfig& l : world.lane_lines) {
    const Eigen::Vector2d a(l.x0_m, l.y0_m), b(l.x1_m, l.y1_m);
    const double len = (b - a).norm();
    const Eigen::Vector2d u = (b - a) / len;
    // Split long lines into pieces so that the floor grid stays selective.
    const double piece = l.dash_m > 0 ? l.dash_m + l.gap_m : 0.25;
    for (double s0 = 0; s0 < len; s0 += piece) {
      FloorFeature f;
      const double s1 = std::min(len, s0 + (l.dash_m > 0 ? l.dash_m : piece));
      f.c = a + 0.5 * (s0 + s1) * u;
      f.u = u;
      f.hu = 0.5 * (s1 - s0);
      f.hv = 0.5 * l.width_m;
      f.color = l.color == "yellow" ? kLaneYellow : kLaneWhite;
      features_.push_back(std::move(f));
    }
  }
  // Grid over the features' extent.
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const FloorFeature& f : features_) {
    const double r = std::hypot(f.hu, f.hv);
    x0 = std::min(x0, f.c.x() - r);
    y0 = std::min(y0, f.c.y() - r);
    x1 = std::max(x1, f.c.x() + r);
    y1 = std::max(y1, f.c.y() + r);
  }
  for (const FloorFeature& f : features_) {
    const double ex = std::abs(f.u.x()) * f.hu + std::abs(f.u.y()) * f.hv;
    const double ey = std::abs(f.u.y()) * f.hu + std::abs(f.u.x()) * f.hv;
    feature_boxes_.push_back({f.c.x() - ex, f.c.x() + ex, f.c.y() - ey, f.c.y() + ey});
  }
  if (!features_.empty()) {
    grid_x0_ = x0;
    grid_y0_ = y0;
    grid_nx_ = std::max(1, static_cast<int>(std::ceil((x1 - x0) / grid_cell_)));
    grid_ny_ = std::max(1, static_cast<int>(std::ceil((y1 - y0) / grid_cell_)));
    grid_.assign(static_cast<size_t>(grid_nx_ * grid_ny_), {});
    for (size_t i = 0; i < features_.size(); ++i) {
      const FloorFeature& f = features_[i];
      const double r = std::hypot(f.hu, f.hv);
      const int ix0 = std::max(0, static_cast<int>((f.c.x() - r - x0) / grid_cell_));
      const int ix1 = std::min(grid_nx_ - 1, static_cast<int>((f.c.x() + r - x0) / grid_cell_));
      const int iy0 = std::max(0, static_cast<int>((f.c.y() - r - y0) / grid_cell_));
      const int iy1 = std::min(grid_ny_ - 1, static_cast<int>((f.c.y() + r - y0) / grid_cell_));
      for (int iy = iy0; iy <= iy1; ++iy) {
        for (int ix = ix0; ix <= ix1; ++ix) grid_[iy * grid_nx_ + ix].push_back(static_cast<int>(i));
      }
    }
  }
  bins_.assign(kAzimuthBins + 1, {});
  bin_min_dist2_.assign(kAzimuthBins + 1, 0.0);
  if (next_id > kSurfaceMask) throw ConfigError("renderer: the world has too many surfaces");
  quad_of_id_.assign(static_cast<size_t>(next_id), -1);
  top_of_id_.assign(static_cast<size_t>(next_id), -1);
  for (size_t i = 0; i < quads_.size(); ++i) quad_of_id_[static_cast<size_t>(quads_[i].id)] = static_cast<int>(i);
  for (size_t k = 0; k < tops_.size(); ++k) top_of_id_[static_cast<size_t>(tops_[k].id)] = static_cast<int>(k);
}

namespace {
int azimuthBin(double azimuth_rad) {
  double a = std::fmod(azimuth_rad + M_PI, 2 * M_PI);
  if (a < 0) a += 2 * M_PI;
  int b = static_cast<int>(a / (2 * M_PI) * kAzimuthBins);
  return std::min(b, kAzimuthBins - 1);
}
}  // namespace

void Scene::prepare(const Eigen::Vector3d& o, double yaw_rad) const {
  for (auto& b : bins_) b.clear();
  std::fill(bin_min_dist2_.begin(), bin_min_dist2_.end(), std::numeric_limits<double>::infinity());
  visible_tops_.clear();
  for (size_t k = 0; k < tops_.size(); ++k) {
    if (tops_[k].z < o.z()) visible_tops_.push_back(static_cast<int>(k));  // seen from above only
  }
  for (size_t i = 0; i < quads_.size(); ++i) {
    const VerticalQuad& q = quads_[i];
    bins_[kAllBins].push_back(static_cast<int>(i));
    const Eigen::Vector2d o2(o.x(), o.y());
    const Eigen::Vector2d a = q.p0 - o2, b = q.p0 + q.length * q.dir - o2;
    // Every quad is tested by rays whose azimuth lies within the arc it spans from the camera
    // (shorter than half a turn, unless the camera stands in the quad's plane: then all bins).
    const double a0 = std::atan2(a.y(), a.x()), a1 = std::atan2(b.y(), b.x());
    double span = std::remainder(a1 - a0, 2 * M_PI);
    double start = span >= 0 ? a0 : a1;
    span = std::abs(span);
    const double cross = a.x() * b.y() - a.y() * b.x();
    if (std::abs(cross) < 1e-9 * a.norm() * b.norm() && a.dot(b) < 0) {
      start = -M_PI;
      span = 2 * M_PI;
    }
    // Nearest point of the quad's footprint to the camera: a floor hit nearer than every quad of
    // its bin needs no quad test.
    const double along = std::clamp(-a.dot(q.dir), 0.0, q.length);
    const double dist2 = (a + along * q.dir).squaredNorm();
    bin_min_dist2_[kAllBins] = std::min(bin_min_dist2_[kAllBins], dist2);
    const int first = azimuthBin(start - yaw_rad) - kBinPadding;
    const int count = static_cast<int>(span / (2 * M_PI) * kAzimuthBins) + 1 + 2 * kBinPadding;
    for (int k = 0; k < std::min(count, kAzimuthBins); ++k) {
      const int bin = ((first + k) % kAzimuthBins + kAzimuthBins) % kAzimuthBins;
      bins_[bin].push_back(static_cast<int>(i));
      bin_min_dist2_[bin] = std::min(bin_min_dist2_[bin], dist2);
    }
  }
}

Rgb Scene::floorColor(double x, double y, bool* marked) const {
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

bool Scene::floorAreaHoldsNoMark(double x0, double x1, double y0, double y1) const {
  if (grid_.empty()) return true;
  constexpr double kMargin_m = 1e-3;  // the lens bends a block's edges by far less
  x0 -= kMargin_m;
  x1 += kMargin_m;
  y0 -= kMargin_m;
  y1 += kMargin_m;
  const int ix0 = std::max(0, static_cast<int>(std::floor((x0 - grid_x0_) * inv_grid_cell_)));
  const int ix1 = std::min(grid_nx_ - 1, static_cast<int>(std::floor((x1 - grid_x0_) * inv_grid_cell_)));
  const int iy0 = std::max(0, static_cast<int>(std::floor((y0 - grid_y0_) * inv_grid_cell_)));
  const int iy1 = std::min(grid_ny_ - 1, static_cast<int>(std::floor((y1 - grid_y0_) * inv_grid_cell_)));
  if (ix0 > ix1 || iy0 > iy1) return true;            // beyond the grid: no marks there
  if ((ix1 - ix0 + 1) * (iy1 - iy0 + 1) > 16) return false;  // a far, large footprint: do not bother
  for (int iy = iy0; iy <= iy1; ++iy) {
    for (int ix = ix0; ix <= ix1; ++ix) {
      for (int i : grid_[static_cast<size_t>(iy * grid_nx_ + ix)]) {
        const std::array<double, 4>& b = feature_boxes_[static_cast<size_t>(i)];
        if (b[0] <= x1 && b[1] >= x0 && b[2] <= y1 && b[3] >= y0) return false;
      }
    }
  }
  return true;
}

Rgb Scene::boardColor(const VerticalQuad& q, double s, double z, int* cell) const {
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

Rgb Scene::wallColor(const VerticalQuad& q, double s, double z, int* part) const {
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

inline void Scene::trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d, uint16_t bin,
                         Rgb* color, int* id, double* distance, Eigen::Vector2f* plane) const {
  double best = std::numeric_limits<double>::infinity();
  int hit = -1;  // -1 nothing, -2 floor, -3 - k: top k, >= 0: quad
  double hit_s = 0;
  bool quads_possible = true;
  if (d.z() < 0) {
    best = -o.z() / d.z();
    hit = -2;
    quads_possible = best * best * (d.x() * d.x() + d.y() * d.y()) >= bin_min_dist2_[bin];
  }
  if (quads_possible) for (int i : bins_[bin]) {
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
  for (int k : visible_tops_) {
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
    *color = floorColor(x, y, &marked);
    *id = marked ? (1 | kMarked) : 1;
    if (plane) *plane = Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y));
  } else if (hit <= -3) {
    const HorizontalRect& r = tops_[static_cast<size_t>(-3 - hit)];
    *color = r.color;
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
    *color = quadColor(q, surface, hit_s, z, &part);
    *id = q.id + (part << 16);
  }
}

inline Rgb Scene::quadColor(const VerticalQuad& q, Surface surface, double s, double z, int* part) const {
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

inline Rgb Scene::colorOn(int surface, const Eigen::Vector2f& at, const Eigen::Vector3d& o) const {
  if (surface == 1) {
    bool marked = false;
    return floorColor(at.x(), at.y(), &marked);
  }
  const int top = top_of_id_[static_cast<size_t>(surface)];
  if (top >= 0) return tops_[static_cast<size_t>(top)].color;
  const VerticalQuad& q = quads_[static_cast<size_t>(quad_of_id_[static_cast<size_t>(surface)])];
  // The camera sees the quad's front when it stands on the side its front normal points to.
  const bool front = (o.x() - q.p0.x()) * q.front.x() + (o.y() - q.p0.y()) * q.front.y() > 0;
  int part = 0;
  return quadColor(q, front ? q.front_surface : q.back_surface, at.x(), at.y(), &part);
}

// -----------------------------------------------------------------------------------------------

Renderer::Renderer(const CameraConfig& camera, const WorldConfig& world,
                   const RenderOptions& options)
    : config_(camera),
      camera_(camera.truth),
      options_(options),
      scene_(std::make_unique<Scene>(world)),
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
}

Renderer::~Renderer() = default;

void Renderer::renderPose(const Pose2& pose, bool antialias, bool sum_blocks, bool store,
                          float* acc) const {
  const Eigen::Vector3d origin = cameraInWorld(config_, pose).translation();
  scene_->prepare(origin, pose.yaw_rad);
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
    scene_->trace(origin, dw, corner_bins_[i], &color[i], &id[i], &distance, &corner_plane_[i]);
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
        const Rgb col = scene_->colorOn(surface, l + (r - l) * t.x(), origin);
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
      scene_->trace(origin, dw, bin, &col, &sample_id);
      sb += col.b;
      sg += col.g;
      sr += col.r;
    }
    put(out, sb * inv_samples, sg * inv_samples, sr * inv_samples);
  };

  if (width_ % 2 != 0 || height_ % 2 != 0) {
    for (size_t i = 0; i < corner_dirs_.size(); ++i) traceCorner(i);
    for (int v = 0; v < height_; ++v) {
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
      if (!scene_->floorAreaHoldsNoMark(std::min(std::min(pa.x(), pb.x()), std::min(pe.x(), pf.x())),
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
    for (int v = 0; v < height_; v += 2) {
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
  for (int v = 0; v < height_; v += 4) {
    for (int u = 0; u < width_; u += 4) block4(u, v);
  }
}

cv::Mat Renderer::renderExact(const Pose2& pose) const {
  cv::Mat acc(height_, width_, CV_32FC3);
  renderPose(pose, true, false, true, acc.ptr<float>());
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

const cv::Mat& Renderer::renderNoiseless(const std::vector<Pose2>& poses) const {
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
    for (const Pose2& p : poses) renderPose(p, still, sum_blocks, still, acc.ptr<float>());
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

cv::Mat Renderer::render(const std::vector<Pose2>& poses, std::mt19937_64& rng) const {
  if (poses.empty()) throw InputError("renderer: no pose to render");
  const cv::Mat& acc = renderNoiseless(poses);
  cv::Mat out(height_, width_, CV_8UC3);
  if (noise_table_.empty()) {  // no noise
    acc.convertTo(out, CV_8UC3);
    return out;
  }
  const size_t n = static_cast<size_t>(width_) * height_ * 3;
  const size_t offset = std::uniform_int_distribution<size_t>(0, noise_table_.size() - n)(rng);
  // Noise added, then rounded and saturated to 0..255, row by row through a one-row buffer that
  // stays in the cache (an image-sized float buffer in between cost memory traffic: a large part
  // of a frame's time is moving image-sized buffers).
  const cv::Mat noise(height_, width_, CV_32FC3, const_cast<float*>(noise_table_.data() + offset));
  for (int v = 0; v < height_; ++v) {
    cv::scaleAdd(noise.row(v), options_.noise_sigma, acc.row(v), noisy_row_);
    noisy_row_.convertTo(out.row(v), CV_8UC3);  // rounds and saturates to 0..255
  }
  return out;
}

}  // namespace sim
}  // namespace autocal
