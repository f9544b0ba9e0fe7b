#include "autocal/sim/simulation.h"

#include <box2d/box2d.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "autocal/errors.h"
#include "autocal/sim/scene.h"

namespace autocal {
namespace sim {

namespace {
constexpr double kGravity = 9.81;

b2Vec2 vec(const Eigen::Vector2d& v) { return b2Vec2(static_cast<float>(v.x()), static_cast<float>(v.y())); }
Eigen::Vector2d vec(const b2Vec2& v) { return {v.x, v.y}; }
double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

void addStaticBox(b2World* world, const Eigen::Vector2d& centre, double yaw, double half_length,
                  double half_width) {
  b2BodyDef def;
  def.type = b2_staticBody;
  def.position = vec(centre);
  def.angle = static_cast<float>(yaw);
  b2Body* body = world->CreateBody(&def);
  b2PolygonShape shape;
  shape.SetAsBox(static_cast<float>(half_length), static_cast<float>(half_width));
  b2FixtureDef fixture;
  fixture.shape = &shape;
  fixture.friction = 0.5f;
  body->CreateFixture(&fixture);
}

void addSegmentBox(b2World* world, double x0, double y0, double x1, double y1, double thickness) {
  const Eigen::Vector2d a(x0, y0), b(x1, y1);
  addStaticBox(world, 0.5 * (a + b), std::atan2(b.y() - a.y(), b.x() - a.x()), 0.5 * (b - a).norm(),
               0.5 * thickness);
}

class NearestHit : public b2RayCastCallback {
 public:
  explicit NearestHit(const b2Body* ignore) : ignore_(ignore) {}
  float ReportFixture(b2Fixture* fixture, const b2Vec2&, const b2Vec2&, float fraction) override {
    if (fixture->GetBody() == ignore_) return -1.0f;  // the robot does not see itself
    if (fraction < fraction_) fraction_ = fraction;
    return fraction;
  }
  float fraction_ = 2.0f;

 private:
  const b2Body* ignore_;
};
}  // namespace

double steadyWheelSpeed(double duty, double gain, double motor_constant, double deadband) {
  const double magnitude = std::abs(duty);
  if (magnitude <= deadband) return 0.0;
  const double speed = gain * motor_constant * (std::min(magnitude, 1.0) - deadband) / (1.0 - deadband);
  return duty > 0 ? speed : -speed;
}

Simulation::Simulation(const RobotConfig& robot, const WorldConfig& world,
                       const SimulationOptions& options)
    : robot_(robot), options_(options), slip_rng_(options.seed) {
  if (!(options_.physics_rate_hz >= 50 && options_.physics_rate_hz <= 100000)) {
    throw ConfigError("physics_rate_hz must be within 50..100000");
  }
  dt_s_ = 1.0 / options_.physics_rate_hz;
  radius_m_[0] = robot.wheel_radius_left;
  radius_m_[1] = robot.wheel_radius_right;
  // The rest of a coast from speed w, integrated as step() does (this step's turn, then the lag's
  // geometric decay): w * dt / (1 - decay). Held below the speed where that is 1/20 encoder tick.
  if (options_.hold_stopped_wheels && robot_.motor_time_constant > 0) {
    const double decay = std::exp(-dt_s_ / robot_.motor_time_constant);
    stop_speed_rad_s_ = (2 * M_PI / robot_.encoder_resolution) / 20.0 * (1.0 - decay) / dt_s_;
  }
  gain_[0] = robot.motor_gain_left;
  gain_[1] = robot.motor_gain_right;

  world_ = std::make_unique<b2World>(b2Vec2(0.0f, 0.0f));  // seen from above: no gravity in plane
  world_->SetAllowSleeping(false);
  for (const WallConfig& w : world.walls) addSegmentBox(world_.get(), w.x0_m, w.y0_m, w.x1_m, w.y1_m, w.thickness_m);
  for (const ChessboardConfig& b : world.chessboards) {
    // The board's footprint on its stand.
    const Eigen::Vector2d c(b.pose.x_m, b.pose.y_m), r = boardRight(b);
    addSegmentBox(world_.get(), (c - 0.5 * boardWidth(b) * r).x(), (c - 0.5 * boardWidth(b) * r).y(),
                  (c + 0.5 * boardWidth(b) * r).x(), (c + 0.5 * boardWidth(b) * r).y(), 0.02);
  }
  for (const ObstacleConfig& o : world.obstacles) {
    addStaticBox(world_.get(), Eigen::Vector2d(o.pose.x_m, o.pose.y_m), o.pose.yaw_rad, 0.5 * o.length_m,
                 0.5 * o.width_m);
  }

  b2BodyDef def;
  def.type = b2_dynamicBody;
  def.position.Set(static_cast<float>(world.robot_start.x_m), static_cast<float>(world.robot_start.y_m));
  def.angle = static_cast<float>(world.robot_start.yaw_rad);
  def.allowSleep = false;
  def.bullet = true;
  body_ = world_->CreateBody(&def);
  b2PolygonShape chassis;
  chassis.SetAsBox(static_cast<float>(0.5 * robot.chassis_length_m), static_cast<float>(0.5 * robot.chassis_width_m),
                   b2Vec2(static_cast<float>(robot.chassis_offset_x_m), 0.0f), 0.0f);
  b2FixtureDef fixture;
  fixture.shape = &chassis;
  fixture.density = static_cast<float>(robot.mass_kg / (robot.chassis_length_m * robot.chassis_width_m));
  fixture.friction = 0.3f;
  body_->CreateFixture(&fixture);

  // Static load on the wheels: the weight is shared between the axle and the caster by the
  // lever rule about the centre of mass.
  const double com_x = body_->GetLocalCenter().x;
  double axle_share = 1.0;
  if (std::abs(robot.caster_x_m) > 1e-6) {
    axle_share = std::clamp((com_x - robot.caster_x_m) / (0.0 - robot.caster_x_m), 0.05, 1.0);
  }
  normal_load_n_[0] = normal_load_n_[1] = 0.5 * axle_share * robot.mass_kg * kGravity;
  history_.push_back({0.0, pose()});
  unwrapped_yaw_rad_ = world.robot_start.yaw_rad;
}

Simulation::~Simulation() = default;

void Simulation::setDuty(double left, double right) {
  if (!std::isfinite(left) || !std::isfinite(right)) {
    throw InputError("wheel duty must be finite (got " + std::to_string(left) + ", " +
                     std::to_string(right) + ")");
  }
  duty_[0] = std::clamp(left, -1.0, 1.0);
  duty_[1] = std::clamp(right, -1.0, 1.0);
}

Pose2 Simulation::pose() const {
  const b2Vec2 p = body_->GetPosition();
  Pose2 out;
  out.x_m = p.x;
  out.y_m = p.y;
  out.yaw_rad = std::remainder(static_cast<double>(body_->GetAngle()), 2 * M_PI);
  return out;
}

double Simulation::forwardSpeed() const {
  const b2Vec2 v = body_->GetLinearVelocityFromLocalPoint(b2Vec2(0, 0));
  const double a = body_->GetAngle();
  return v.x * std::cos(a) + v.y * std::sin(a);
}

double Simulation::yawRate() const { return body_->GetAngularVelocity(); }

Eigen::Vector2d Simulation::wheelContact(Side side) const {
  const double y = (side == Side::kLeft ? 0.5 : -0.5) * robot_.wheelbase;
  return vec(body_->GetWorldPoint(b2Vec2(0.0f, static_cast<float>(y))));
}

int32_t Simulation::encoderTicks(Side side) const {
  const double revolutions = wheel_angle_rad_[static_cast<int>(side)] / (2 * M_PI);
  return static_cast<int32_t>(std::floor(revolutions * robot_.encoder_resolution));
}

void Simulation::applyTraction() {
  // Three velocity constraints (no lengthwise slip at each wheel, no sideways slip of the axle;
  // the two wheels' sideways constraints are the same one), solved exactly for three impulses.
  const double angle = body_->GetAngle();
  const Eigen::Vector2d t(std::cos(angle), std::sin(angle)), n(-t.y(), t.x());
  const Eigen::Vector2d c = vec(body_->GetWorldCenter());
  const double m = body_->GetMass();
  const Eigen::Vector2d local_c = vec(body_->GetLocalCenter());
  const double inertia = body_->GetInertia() - m * local_c.squaredNorm();  // about the centre
  const Eigen::Vector2d v = vec(body_->GetLinearVelocity());
  const double w = body_->GetAngularVelocity();

  const Eigen::Vector2d points[3] = {wheelContact(Side::kLeft), wheelContact(Side::kRight),
                                     vec(body_->GetWorldPoint(b2Vec2(0, 0)))};
  const Eigen::Vector2d dirs[3] = {t, t, n};
  // A slipping wheel's contact point moves by (1 - slip) of its rim's speed.
  const double targets[3] = {radius_m_[0] * wheel_speed_rad_s_[0] * (1.0 - slip_[0]),
                             radius_m_[1] * wheel_speed_rad_s_[1] * (1.0 - slip_[1]), 0.0};
  Eigen::Matrix3d A;
  Eigen::Vector3d error;
  double arm[3];
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector2d r = points[j] - c;
    arm[j] = cross(r, dirs[j]);
    const Eigen::Vector2d vp(v.x() - w * r.y(), v.y() + w * r.x());
    error(j) = vp.dot(dirs[j]) - targets[j];
  }
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 3; ++k) A(j, k) = dirs[j].dot(dirs[k]) / m + arm[j] * arm[k] / inertia;
  }
  Eigen::Vector3d impulse = A.fullPivLu().solve(-error);
  // Traction limit: a wheel transmits at most friction x load; beyond it both wheels slip and the
  // impulses are scaled down together.
  double scale = 1.0;
  for (int i = 0; i < 2; ++i) {
    const double needed = std::hypot(impulse(i), 0.5 * impulse(2));
    const double limit = robot_.wheel_friction * normal_load_n_[i] * dt_s_;
    if (needed > limit) scale = std::min(scale, limit / needed);
  }
  impulse *= scale;
  for (int j = 0; j < 3; ++j) {
    body_->ApplyLinearImpulse(vec(impulse(j) * dirs[j]), vec(points[j]), true);
  }
}

void Simulation::step() {
  // Motors: first-order lag towards the steady speed of the duty, integrated exactly.
  const double tau = robot_.motor_time_constant;
  const double blend = tau > 0 ? 1.0 - std::exp(-dt_s_ / tau) : 1.0;
  const double drift = 1.0 + robot_.gain_drift_per_min * time_s_ / 60.0;
  if (robot_.wheel_slip_sigma > 0 && time_s_ >= next_slip_s_) {
    // Each wheel's slip: a new draw every wheel_slip_interval_s.
    std::normal_distribution<double> slip(0.0, robot_.wheel_slip_sigma);
    for (double& s : slip_) s = std::clamp(slip(slip_rng_), -0.5, 0.5);
    next_slip_s_ = time_s_ + robot_.wheel_slip_interval_s;
  }
  for (int i = 0; i < 2; ++i) {
    const double backward_ratio =
        i == 0 ? robot_.backward_gain_ratio_left : robot_.backward_gain_ratio_right;
    const double gain = gain_[i] * drift * (duty_[i] < 0 ? backward_ratio : 1.0);
    double target = steadyWheelSpeed(duty_[i], gain, robot_.motor_constant, robot_.deadband);
    // Static friction: a motor at rest needs the breakaway duty to start; once turning, the
    // running deadband holds.
    const double breakaway =
        std::max(robot_.deadband, i == 0 ? robot_.breakaway_duty_left : robot_.breakaway_duty_right);
    if (motor_speed_rad_s_[i] == 0.0 && std::abs(duty_[i]) <= breakaway) target = 0.0;
    motor_speed_rad_s_[i] += (target - motor_speed_rad_s_[i]) * blend;
    // A coasting wheel that has all but stopped is held by the gearbox's friction: the lag alone
    // lets it creep on, ever slower (the pose moves for about 0.6 s, until its steps fall below
    // the body's float resolution), and every frame of a creeping robot is rendered anew. It stops
    // where the rest of its coast would turn it by a twentieth of an encoder tick or less (below
    // about 0.046 rad/s for 135 ticks and 0.05 s): no encoder reading and no pose a stage measures
    // changes by more than that.
    if (target == 0.0 && std::abs(motor_speed_rad_s_[i]) < stop_speed_rad_s_) motor_speed_rad_s_[i] = 0.0;
    // Gearbox backlash: the motor crosses the play (backlash_rad at the wheel) before the wheel
    // follows it the other way; meanwhile the wheel, and its encoder, stand. Where the motor
    // meets the gear across the play, it stops against the robot's far larger inertia and starts
    // again with its lag (the load takes up the play without a jerk).
    double turn_rad = motor_speed_rad_s_[i] * dt_s_;
    if (robot_.backlash_rad > 0) {
      const double half = 0.5 * robot_.backlash_rad;
      const bool crossing = std::abs(play_rad_[i]) < half;
      play_rad_[i] += turn_rad;
      turn_rad = 0.0;
      if (std::abs(play_rad_[i]) > half) {
        if (crossing) {
          motor_speed_rad_s_[i] = 0.0;
        } else {
          turn_rad = play_rad_[i] - std::copysign(half, play_rad_[i]);
        }
        play_rad_[i] = std::copysign(half, play_rad_[i]);
      }
    }
    wheel_speed_rad_s_[i] = turn_rad / dt_s_;
  }
  applyTraction();
  world_->Step(static_cast<float>(dt_s_), options_.velocity_iterations, options_.position_iterations);
  for (int i = 0; i < 2; ++i) wheel_angle_rad_[i] += wheel_speed_rad_s_[i] * dt_s_;
  ++steps_;
  time_s_ = steps_ * dt_s_;
  Pose2 p = pose();
  unwrapped_yaw_rad_ += std::remainder(p.yaw_rad - unwrapped_yaw_rad_, 2 * M_PI);
  p.yaw_rad = unwrapped_yaw_rad_;
  history_.push_back({time_s_, p});
  while (history_.size() > 2 && history_.front().t_s < time_s_ - options_.pose_history_s) history_.pop_front();
}

void Simulation::advance(double duration_s) {
  const auto n = static_cast<uint64_t>(std::llround(duration_s / dt_s_));
  for (uint64_t i = 0; i < n; ++i) step();
}

Pose2 pivotPose(const Pose2& start, double wheelbase_m, Side stopped, double yaw_rad) {
  const double half = (stopped == Side::kLeft ? 0.5 : -0.5) * wheelbase_m;  // contact, left of centre
  const double cx = start.x_m - half * std::sin(start.yaw_rad), cy = start.y_m + half * std::cos(start.yaw_rad);
  return {cx + half * std::sin(yaw_rad), cy - half * std::cos(yaw_rad), yaw_rad};
}

std::vector<Pose2> Simulation::exposurePoses(double capture_s, int max_samples) const {
  const CameraConfig& camera = robot_.camera;
  const double t0_s = capture_s - camera.exposure_s;
  const std::vector<Pose2> ends = posesDuring(t0_s, capture_s, 2);
  const double turn_rad = std::abs(std::remainder(ends[1].yaw_rad - ends[0].yaw_rad, 2 * M_PI));
  const double shift_m = std::hypot(ends[1].x_m - ends[0].x_m, ends[1].y_m - ends[0].y_m);
  // Image motion: the turn, plus the shift as seen on a surface 0.3 m away.
  const double motion_px = camera.truth.fx * (turn_rad + shift_m / 0.3);
  const int samples = std::clamp(static_cast<int>(std::ceil(motion_px)), 1, std::max(1, max_samples));
  return posesDuring(t0_s, capture_s, samples);
}

std::vector<std::vector<Pose2>> Simulation::rollingExposurePoses(double capture_s, int max_samples,
                                                                 int band_rows) const {
  const CameraConfig& camera = robot_.camera;
  const int height = camera.truth.height;
  std::vector<std::vector<Pose2>> bands;
  for (int v0 = 0; v0 < height; v0 += std::max(1, band_rows)) {
    const double middle_row = 0.5 * (v0 + std::min(height, v0 + band_rows));
    bands.push_back(
        exposurePoses(capture_s - camera.readout_s * (1.0 - middle_row / height), max_samples));
  }
  return bands;
}

std::vector<Pose2> Simulation::posesDuring(double t0_s, double t1_s, int samples) const {
  std::vector<Pose2> out;
  samples = std::max(samples, 1);
  for (int k = 0; k < samples; ++k) {
    const double t = samples == 1 ? t1_s : t0_s + (t1_s - t0_s) * k / (samples - 1);
    auto it = std::lower_bound(history_.begin(), history_.end(), t,
                               [](const Stamped& s, double tt) { return s.t_s < tt; });
    Pose2 p;
    if (it == history_.begin()) {
      p = it->pose;
    } else if (it == history_.end()) {
      p = history_.back().pose;
    } else {
      const Stamped& b = *it;
      const Stamped& a = *(it - 1);
      const double f = (t - a.t_s) / (b.t_s - a.t_s);
      p.x_m = a.pose.x_m + f * (b.pose.x_m - a.pose.x_m);
      p.y_m = a.pose.y_m + f * (b.pose.y_m - a.pose.y_m);
      p.yaw_rad = a.pose.yaw_rad + f * (b.pose.yaw_rad - a.pose.yaw_rad);
    }
    p.yaw_rad = std::remainder(p.yaw_rad, 2 * M_PI);
    out.push_back(p);
  }
  return out;
}

double Simulation::castRay(const Eigen::Vector2d& from, const Eigen::Vector2d& dir, double max_m) const {
  NearestHit hit(body_);
  world_->RayCast(&hit, vec(from), vec(from + max_m * dir));
  return hit.fraction_ <= 1.0f ? hit.fraction_ * max_m : std::numeric_limits<double>::infinity();
}

double Simulation::trueRange() const {
  const RangeSensorConfig& s = robot_.range_sensor;
  const Pose2 p = pose();
  const Eigen::Vector2d origin = Eigen::Vector2d(p.x_m, p.y_m) +
                                 Eigen::Rotation2Dd(p.yaw_rad) * Eigen::Vector2d(s.x_m, s.y_m);
  double nearest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < s.rays; ++k) {
    const double offset = s.rays == 1 ? 0.0 : s.field_of_view_rad * (k / (s.rays - 1.0) - 0.5);
    const double a = p.yaw_rad + s.yaw_rad + offset;
    nearest = std::min(nearest, castRay(origin, Eigen::Vector2d(std::cos(a), std::sin(a)), s.max_range_m));
  }
  return nearest;
}

double Simulation::measureRange(std::mt19937_64& rng) const {
  const RangeSensorConfig& s = robot_.range_sensor;
  double r = trueRange();
  if (!std::isfinite(r)) return std::numeric_limits<double>::infinity();
  r += std::normal_distribution<double>(0.0, s.noise_sigma_m)(rng);
  if (r > s.max_range_m) return std::numeric_limits<double>::infinity();
  if (r < s.min_range_m) return -std::numeric_limits<double>::infinity();
  return r;
}

bool Simulation::inContact() const {
  for (const b2ContactEdge* e = body_->GetContactList(); e; e = e->next) {
    if (e->contact->IsTouching()) return true;
  }
  return false;
}

}  // namespace sim
}  // namespace autocal
