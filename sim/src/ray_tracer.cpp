// The ray tracer's world, built once from the config, and its per-view bins; see ray_tracer.h.
#include "ray_tracer.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <cstdlib>

#include "autocal/errors.h"
#include "autocal/sim/scene.h"

namespace autocal {
namespace sim {

namespace tracing {

namespace {

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

}  // namespace

int azimuthBin(double azimuth_rad) {
  double a = std::fmod(azimuth_rad + M_PI, 2 * M_PI);
  if (a < 0) a += 2 * M_PI;
  int b = static_cast<int>(a / (2 * M_PI) * kAzimuthBins);
  return std::min(b, kAzimuthBins - 1);
}
RayTracer::RayTracer(const WorldConfig& world) : world_(world), floor_color_(rgb(world.floor_color)) {
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
  if (next_id > kSurfaceMask) throw ConfigError("renderer: the world has too many surfaces");
  quad_of_id_.assign(static_cast<size_t>(next_id), -1);
  top_of_id_.assign(static_cast<size_t>(next_id), -1);
  for (size_t i = 0; i < quads_.size(); ++i) quad_of_id_[static_cast<size_t>(quads_[i].id)] = static_cast<int>(i);
  for (size_t k = 0; k < tops_.size(); ++k) top_of_id_[static_cast<size_t>(tops_[k].id)] = static_cast<int>(k);
}

void RayTracer::prepare(const Eigen::Vector3d& o, double yaw_rad, TraceView* view) const {
  view->bins.resize(kAzimuthBins + 1);
  for (auto& b : view->bins) b.clear();
  view->bin_min_dist2.assign(kAzimuthBins + 1, std::numeric_limits<double>::infinity());
  view->visible_tops.clear();
  for (size_t k = 0; k < tops_.size(); ++k) {
    if (tops_[k].z < o.z()) view->visible_tops.push_back(static_cast<int>(k));  // seen from above only
  }
  for (size_t i = 0; i < quads_.size(); ++i) {
    const VerticalQuad& q = quads_[i];
    view->bins[kAllBins].push_back(static_cast<int>(i));
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
    view->bin_min_dist2[kAllBins] = std::min(view->bin_min_dist2[kAllBins], dist2);
    const int first = azimuthBin(start - yaw_rad) - kBinPadding;
    const int count = static_cast<int>(span / (2 * M_PI) * kAzimuthBins) + 1 + 2 * kBinPadding;
    for (int k = 0; k < std::min(count, kAzimuthBins); ++k) {
      const int bin = ((first + k) % kAzimuthBins + kAzimuthBins) % kAzimuthBins;
      view->bins[bin].push_back(static_cast<int>(i));
      view->bin_min_dist2[bin] = std::min(view->bin_min_dist2[bin], dist2);
    }
  }
}

bool RayTracer::floorAreaHoldsNoMark(double x0, double x1, double y0, double y1) const {
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

}  // namespace tracing
}  // namespace sim
}  // namespace autocal
