#include "autocal/sim/config.h"

#include <cmath>
#include <random>

#include "autocal/errors.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {
namespace sim {

namespace {

double positive(YamlMap& m, const std::string& key) {
  const double v = m.required<double>(key);
  if (!(v > 0)) m.fail(key, "must be > 0, got " + std::to_string(v));
  return v;
}

double positiveOr(YamlMap& m, const std::string& key, double fallback) {
  const double v = m.optional<double>(key, fallback);
  if (!(v > 0)) m.fail(key, "must be > 0, got " + std::to_string(v));
  return v;
}

double inRange(YamlMap& m, const std::string& key, double fallback, double lo, double hi) {
  const double v = m.optional<double>(key, fallback);
  if (v < lo || v > hi) {
    m.fail(key, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                    std::to_string(v));
  }
  return v;
}

Intrinsics readIntrinsics(YamlMap& m, bool with_size, int width, int height) {
  Intrinsics in;
  if (with_size) {
    in.width = m.required<int>("width");
    in.height = m.required<int>("height");
    if (in.width < 16 || in.height < 16 || in.width > 4096 || in.height > 4096) {
      m.fail("width", "image size must be within 16..4096 px");
    }
  } else {
    in.width = width;
    in.height = height;
  }
  in.fx = positive(m, "fx");
  in.fy = positive(m, "fy");
  in.cx = m.required<double>("cx");
  in.cy = m.required<double>("cy");
  const std::string model = m.required<std::string>("distortion_model");
  try {
    in.distortion_model = parseDistortionModel(model);
  } catch (const ConfigError&) {
    m.fail("distortion_model",
           "must be plumb_bob, rational_polynomial or equidistant, got '" + model + "'");
  }
  in.distortion_coefficients = m.required<std::vector<double>>("distortion_coefficients");
  const size_t n = distortionCoefficientCount(in.distortion_model);
  if (in.distortion_coefficients.size() != n) {
    m.fail("distortion_coefficients", model + " takes " + std::to_string(n) +
                                          " coefficients, got " +
                                          std::to_string(in.distortion_coefficients.size()));
  }
  return in;
}

Pose2 readPose(YamlMap& m) {
  Pose2 p;
  p.x_m = m.required<double>("x_m");
  p.y_m = m.required<double>("y_m");
  p.yaw_rad = m.optional<double>("yaw_rad", 0.0);
  return p;
}

/// A chessboard's keys, standing (chessboards) or lying (floor_boards): cols, rows, square_m,
/// margin_m and the pose.
template <typename Board>
void readBoard(YamlMap& b, Board* c) {
  c->cols = b.required<int>("cols");
  c->rows = b.required<int>("rows");
  if (c->cols < 2 || c->rows < 2 || c->cols > 40 || c->rows > 40) {
    b.fail("cols", "inner corners must be 2..40 in each direction");
  }
  c->square_m = positive(b, "square_m");
  c->margin_m = b.optional<double>("margin_m", c->margin_m);
  if (c->margin_m < 0) b.fail("margin_m", "must be >= 0");
  c->pose = readPose(b);
}

std::vector<double> readColor(YamlMap& m, const std::string& key,
                              const std::vector<double>& fallback) {
  const auto c = m.optional<std::vector<double>>(key, fallback);
  if (c.size() != 3) m.fail(key, "expected [r, g, b]");
  for (double v : c) {
    if (v < 0 || v > 255) m.fail(key, "colour components must be within 0..255");
  }
  return c;
}

RobotConfig readRobot(YamlMap& m) {
  RobotConfig r;
  r.wheel_radius_left = positive(m, "wheel_radius_left");
  r.wheel_radius_right = positive(m, "wheel_radius_right");
  r.wheelbase = positive(m, "wheelbase");
  r.motor_gain_left = positive(m, "motor_gain_left");
  r.motor_gain_right = positive(m, "motor_gain_right");
  r.motor_constant = positive(m, "motor_constant");
  r.deadband = m.required<double>("deadband");
  if (r.deadband < 0 || r.deadband >= 1) m.fail("deadband", "must be in [0, 1)");
  r.motor_time_constant = m.required<double>("motor_time_constant");
  if (r.motor_time_constant < 0) m.fail("motor_time_constant", "must be >= 0");
  r.encoder_resolution = m.required<int>("encoder_resolution");
  if (r.encoder_resolution <= 0) m.fail("encoder_resolution", "must be > 0");
  r.encoder_rate_hz = positiveOr(m, "encoder_rate_hz", r.encoder_rate_hz);
  r.mass_kg = positiveOr(m, "mass_kg", r.mass_kg);
  r.chassis_length_m = positiveOr(m, "chassis_length_m", r.chassis_length_m);
  r.chassis_width_m = positiveOr(m, "chassis_width_m", r.chassis_width_m);
  r.chassis_offset_x_m = m.optional<double>("chassis_offset_x_m", r.chassis_offset_x_m);
  r.caster_x_m = m.optional<double>("caster_x_m", r.caster_x_m);
  r.wheel_friction = positiveOr(m, "wheel_friction", r.wheel_friction);
  for (const char* side : {"left", "right"}) {
    const std::string b = std::string("breakaway_duty_") + side;
    double& breakaway = side[0] == 'l' ? r.breakaway_duty_left : r.breakaway_duty_right;
    breakaway = m.optional<double>(b, r.deadband);
    if (!(breakaway >= r.deadband && breakaway < 1)) m.fail(b, "must be in [deadband, 1)");
    const std::string g = std::string("backward_gain_ratio_") + side;
    (side[0] == 'l' ? r.backward_gain_ratio_left : r.backward_gain_ratio_right) =
        inRange(m, g, 1.0, 0.5, 2.0);
  }
  r.gain_drift_per_min = inRange(m, "gain_drift_per_min", 0.0, -0.05, 0.05);
  r.backlash_rad = inRange(m, "backlash_rad", 0.0, 0.0, 0.2);
  r.wheel_slip_sigma = inRange(m, "wheel_slip_sigma", 0.0, 0.0, 0.1);
  r.wheel_slip_interval_s = inRange(m, "wheel_slip_interval_s", 0.2, 0.001, 10.0);
  if (m.has("transport")) {
    YamlMap t = m.map("transport");
    auto link = [&](const char* key, LinkConfig* l) {
      if (!t.has(key)) return;
      YamlMap k = t.map(key);
      l->latency_s = inRange(k, "latency_s", 0.0, 0.0, 2.0);
      l->jitter_s = inRange(k, "jitter_s", 0.0, 0.0, 1.0);
      l->drop_probability = inRange(k, "drop_probability", 0.0, 0.0, 0.5);
      k.finish();
    };
    link("camera", &r.transport.camera);
    link("encoders", &r.transport.encoders);
    link("range", &r.transport.range);
    link("wheels_cmd", &r.transport.wheels_cmd);
    t.finish();
  }
  if (r.chassis_width_m < r.wheelbase * 0.5) {
    m.fail("chassis_width_m", "must be at least half the wheelbase");
  }

  YamlMap cam = m.map("camera");
  CameraConfig& c = r.camera;
  c.truth = readIntrinsics(cam, true, 0, 0);
  c.noise_sigma = inRange(cam, "noise_sigma", c.noise_sigma, 0.0, 64.0);
  c.height_m = positive(cam, "height_m");
  c.pitch_rad = cam.required<double>("pitch_rad");
  if (std::abs(c.pitch_rad) > 1.4) cam.fail("pitch_rad", "must be within [-1.4, 1.4] rad");
  c.x_m = cam.required<double>("x_m");
  c.y_m = cam.optional<double>("y_m", c.y_m);
  c.yaw_rad = inRange(cam, "yaw_rad", c.yaw_rad, -0.5, 0.5);
  c.roll_rad = inRange(cam, "roll_rad", c.roll_rad, -0.5, 0.5);
  c.rate_hz = positiveOr(cam, "rate_hz", c.rate_hz);
  c.exposure_s = inRange(cam, "exposure_s", c.exposure_s, 0.0, 1.0);
  c.supersampling = cam.optional<int>("supersampling", c.supersampling);
  if (c.supersampling < 1 || c.supersampling > 16) cam.fail("supersampling", "must be 1..16");
  c.jpeg_quality = cam.optional<int>("jpeg_quality", c.jpeg_quality);
  if (c.jpeg_quality < 1 || c.jpeg_quality > 100) cam.fail("jpeg_quality", "must be 1..100");
  c.vignetting = inRange(cam, "vignetting", c.vignetting, 0.0, 0.9);
  c.brightness_sigma = inRange(cam, "brightness_sigma", c.brightness_sigma, 0.0, 0.3);
  c.readout_s = inRange(cam, "readout_s", c.readout_s, 0.0, 0.1);
  if (c.readout_s >= 1.0 / c.rate_hz) {
    cam.fail("readout_s", "must be shorter than a frame period (1 / rate_hz)");
  }
  c.focus_ring_sharp_turns =
      inRange(cam, "focus_ring_sharp_turns", c.focus_ring_sharp_turns, -5.0, 5.0);
  c.defocus_px_per_turn = inRange(cam, "defocus_px_per_turn", c.defocus_px_per_turn, 0.0, 50.0);
  c.focus_distance_m = inRange(cam, "focus_distance_m", c.focus_distance_m, 0.0, 100.0);
  c.defocus_px_per_diopter =
      inRange(cam, "defocus_px_per_diopter", c.defocus_px_per_diopter, 0.0, 10.0);
  YamlMap nominal = cam.map("nominal");
  c.nominal = readIntrinsics(nominal, false, c.truth.width, c.truth.height);
  nominal.finish();
  cam.finish();

  YamlMap rs = m.map("range_sensor");
  RangeSensorConfig& s = r.range_sensor;
  s.x_m = rs.required<double>("x_m");
  s.y_m = rs.required<double>("y_m");
  s.yaw_rad = rs.required<double>("yaw_rad");
  s.field_of_view_rad = inRange(rs, "field_of_view_rad", s.field_of_view_rad, 0.0, 3.0);
  s.min_range_m = rs.required<double>("min_range_m");
  s.max_range_m = positive(rs, "max_range_m");
  if (s.min_range_m < 0 || s.min_range_m >= s.max_range_m) {
    rs.fail("min_range_m", "must be >= 0 and below max_range_m");
  }
  s.noise_sigma_m = inRange(rs, "noise_sigma_m", s.noise_sigma_m, 0.0, 1.0);
  s.rate_hz = positiveOr(rs, "rate_hz", s.rate_hz);
  s.rays = rs.optional<int>("rays", s.rays);
  if (s.rays < 1 || s.rays > 256) rs.fail("rays", "must be 1..256");
  rs.finish();
  m.finish();
  return r;
}

/// The end points x0_m, y0_m, x1_m, y1_m of a lane line or a wall, at least min_length_m apart.
template <class Segment>
void readSegment(YamlMap& m, double min_length_m, const char* too_short, Segment* c) {
  c->x0_m = m.required<double>("x0_m");
  c->y0_m = m.required<double>("y0_m");
  c->x1_m = m.required<double>("x1_m");
  c->y1_m = m.required<double>("y1_m");
  if (std::hypot(c->x1_m - c->x0_m, c->y1_m - c->y0_m) < min_length_m) m.fail("x1_m", too_short);
}

WorldConfig readWorld(YamlMap& m) {
  WorldConfig w;
  if (m.has("robot_start")) {
    YamlMap start = m.map("robot_start");
    w.robot_start = readPose(start);
    start.finish();
  }
  w.floor_color = readColor(m, "floor_color", w.floor_color);
  if (m.has("light_gradient")) {
    YamlMap l = m.map("light_gradient");
    w.light_gradient.x_per_m = l.optional<double>("x_per_m", 0.0);
    w.light_gradient.y_per_m = l.optional<double>("y_per_m", 0.0);
    if (!(std::abs(w.light_gradient.x_per_m) <= 0.5)) l.fail("x_per_m", "must be within +-0.5 [1/m]");
    if (!(std::abs(w.light_gradient.y_per_m) <= 0.5)) l.fail("y_per_m", "must be within +-0.5 [1/m]");
    l.finish();
  }
  for (YamlMap& b : m.optionalMapList("chessboards")) {
    ChessboardConfig c;
    readBoard(b, &c);
    c.center_z_m = positive(b, "center_z_m");
    const double half_height = 0.5 * ((c.rows + 1) * c.square_m) + c.margin_m;
    if (c.center_z_m < half_height) b.fail("center_z_m", "the board would reach below the floor");
    b.finish();
    w.chessboards.push_back(c);
  }
  for (YamlMap& t : m.optionalMapList("floor_tags")) {
    FloorTagConfig c;
    c.id = t.required<int>("id");
    if (c.id < 0 || c.id >= 587) t.fail("id", "tag36h11 ids are 0..586");
    c.size_m = positive(t, "size_m");
    c.pose = readPose(t);
    t.finish();
    w.floor_tags.push_back(c);
  }
  // Placement errors: each tag lies off its nominal place by a Gaussian offset, drawn from the
  // seed; the offsets become the tags' true poses (what the renderer draws).
  if (m.has("floor_tag_placement")) {
    YamlMap e = m.map("floor_tag_placement");
    const double sigma_m = inRange(e, "position_sigma_m", 0.0, 0.0, 0.02);
    const double sigma_rad = inRange(e, "yaw_sigma_rad", 0.0, 0.0, 0.1);
    const int seed = e.optional<int>("seed", 1);
    if (seed < 0) e.fail("seed", "must be >= 0");
    e.finish();
    std::mt19937_64 rng(static_cast<uint64_t>(seed));
    std::normal_distribution<double> unit(0.0, 1.0);
    for (FloorTagConfig& t : w.floor_tags) {
      t.pose.x_m += sigma_m * unit(rng);
      t.pose.y_m += sigma_m * unit(rng);
      t.pose.yaw_rad += sigma_rad * unit(rng);
    }
  }
  for (YamlMap& b : m.optionalMapList("floor_boards")) {
    FloorBoardConfig c;
    readBoard(b, &c);
    b.finish();
    w.floor_boards.push_back(c);
  }
  for (YamlMap& l : m.optionalMapList("lane_lines")) {
    LaneLineConfig c;
    readSegment(l, 1e-6, "the line has no length", &c);
    c.width_m = positive(l, "width_m");
    c.color = l.optional<std::string>("color", c.color);
    if (c.color != "white" && c.color != "yellow") l.fail("color", "must be white or yellow");
    c.dash_m = l.optional<double>("dash_m", 0.0);
    c.gap_m = l.optional<double>("gap_m", 0.0);
    if (c.dash_m < 0 || c.gap_m < 0 || (c.dash_m > 0) != (c.gap_m > 0)) {
      l.fail("dash_m", "dash_m and gap_m must both be 0 (solid) or both > 0");
    }
    l.finish();
    w.lane_lines.push_back(c);
  }
  for (YamlMap& wl : m.optionalMapList("walls")) {
    WallConfig c;
    readSegment(wl, 1e-3, "the wall has no length", &c);
    c.height_m = positive(wl, "height_m");
    c.thickness_m = positiveOr(wl, "thickness_m", c.thickness_m);
    c.texture_seed = static_cast<uint32_t>(wl.optional<int>("texture_seed", 1));
    wl.finish();
    w.walls.push_back(c);
  }
  for (YamlMap& o : m.optionalMapList("obstacles")) {
    ObstacleConfig c;
    c.pose = readPose(o);
    c.length_m = positive(o, "length_m");
    c.width_m = positive(o, "width_m");
    c.height_m = positive(o, "height_m");
    c.color = readColor(o, "color", c.color);
    o.finish();
    w.obstacles.push_back(c);
  }
  m.finish();
  return w;
}

}  // namespace

RobotConfig loadRobotConfig(const std::string& path) {
  YamlMap m = YamlMap::loadFile(path);
  return readRobot(m);
}

WorldConfig loadWorldConfig(const std::string& path) {
  YamlMap m = YamlMap::loadFile(path);
  return readWorld(m);
}

RobotConfig parseRobotConfig(const std::string& yaml, const std::string& name) {
  YamlMap m = YamlMap::fromString(yaml, name);
  return readRobot(m);
}

WorldConfig parseWorldConfig(const std::string& yaml, const std::string& name) {
  YamlMap m = YamlMap::fromString(yaml, name);
  return readWorld(m);
}

}  // namespace sim
}  // namespace autocal
