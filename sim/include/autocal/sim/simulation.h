// The simulated robot and world: Box2D physics of a wheel-level differential drive.
//
// Each wheel has its own true radius and motor gain; a duty in [-1, 1] becomes a wheel speed
// through the motor constant, a deadband and a first-order lag (a coasting wheel that has all but
// stopped is held: it stops within 1/20 of an encoder tick of where the lag would creep it). The wheels move the chassis only
// through impulses at their contact points that make the contact point roll without slipping,
// sideways or lengthwise, up to the wheel's traction limit (friction x normal load): the body
// velocity is never set directly, so collisions with walls, board stands and obstacles push back
// and a wheel that cannot grip slips (its encoder still counts its rotation). What a real motor
// adds is optional (RobotConfig): static friction (a breakaway duty above the running deadband,
// from rest), a gain that differs backward, a gain that drifts with time, gearbox backlash (the
// wheel stands while the motor crosses the play after a reversal) and a small random slip of each
// wheel (its contact point moves by 1 - slip of its rim's speed, slip redrawn at intervals).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <memory>
#include <random>
#include <vector>

#include "autocal/sim/config.h"

class b2World;
class b2Body;

namespace autocal {
namespace sim {

enum class Side { kLeft = 0, kRight = 1 };

/// The pose of a robot that stood at `start` and has since pivoted on its stopped wheel to
/// heading yaw_rad (the wheel's contact point stays where it was).
Pose2 pivotPose(const Pose2& start, double wheelbase_m, Side stopped, double yaw_rad);

struct SimulationOptions {
  double physics_rate_hz = 1000.0;
  int velocity_iterations = 8;
  int position_iterations = 3;
  double pose_history_s = 0.5;  ///< poses kept for motion blur
  /// A coasting wheel is held once the rest of its coast is 1/20 encoder tick or less (false: the
  /// lag alone lets it creep on, ever slower, for about 0.6 s; the code before, for the
  /// benchmark's side by side).
  bool hold_stopped_wheels = true;
  uint64_t seed = 1;  ///< of the wheels' random slip (RobotConfig::wheel_slip_sigma)
};

/// Steady-state wheel speed [rad/s] of a motor for a duty in [-1, 1]: zero within the deadband,
/// then rising linearly to gain * motor_constant at |duty| = 1.
double steadyWheelSpeed(double duty, double gain, double motor_constant, double deadband);

class Simulation {
 public:
  Simulation(const RobotConfig& robot, const WorldConfig& world, const SimulationOptions& options);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Sets the wheel duties. Values are clamped to [-1, 1]; a non-finite value throws InputError.
  void setDuty(double left, double right);
  double duty(Side side) const { return duty_[static_cast<int>(side)]; }

  /// One physics step of 1 / physics_rate_hz.
  void step();
  /// Steps until `duration_s` more has passed (rounded to whole steps).
  void advance(double duration_s);

  double time_s() const { return time_s_; }
  double timestep_s() const { return dt_s_; }
  uint64_t steps() const { return steps_; }

  /// True pose of the axle centre.
  Pose2 pose() const;
  /// True forward speed [m/s] of the axle centre and yaw rate [rad/s].
  double forwardSpeed() const;
  double yawRate() const;
  /// True world position of a wheel's contact point.
  Eigen::Vector2d wheelContact(Side side) const;
  /// Cumulative wheel rotation [rad] and current wheel speed [rad/s] (the motor's, but for the
  /// gearbox's play: RobotConfig::backlash_rad).
  double wheelAngle(Side side) const { return wheel_angle_rad_[static_cast<int>(side)]; }
  double wheelSpeed(Side side) const { return wheel_speed_rad_s_[static_cast<int>(side)]; }
  /// Cumulative encoder ticks: the wheel rotation quantised to the encoder resolution.
  int32_t encoderTicks(Side side) const;

  /// Robot poses at `samples` instants evenly spread over [t0_s, t1_s] (clamped to the history).
  std::vector<Pose2> posesDuring(double t0_s, double t1_s, int samples) const;
  /// The poses a frame captured at capture_s is rendered from: as many over the camera's exposure
  /// as the image moves by pixels (at most max_samples), so a still robot gives one pose and a
  /// moving one a motion-blurred frame.
  std::vector<Pose2> exposurePoses(double capture_s, int max_samples) const;
  /// A rolling shutter's frame (CameraConfig::readout_s > 0) whose readout ended at capture_s: per
  /// band of band_rows image rows from the top, the exposure poses of the band's middle row, whose
  /// exposure ends readout_s * (1 - row / height) before capture_s.
  std::vector<std::vector<Pose2>> rollingExposurePoses(double capture_s, int max_samples,
                                                       int band_rows) const;

  /// Range sensor: the nearest obstacle over the sensor's cone [m] without noise; +inf when
  /// nothing is within max_range_m.
  double trueRange() const;
  /// A reading as the sensor reports it (REP 117): noise added; -inf below min_range_m, +inf
  /// beyond max_range_m.
  double measureRange(std::mt19937_64& rng) const;

  /// Whether the chassis touches a static body (wall, board stand, obstacle).
  bool inContact() const;

  const RobotConfig& robot() const { return robot_; }

 private:
  void applyTraction();
  double castRay(const Eigen::Vector2d& from, const Eigen::Vector2d& dir, double max_m) const;

  RobotConfig robot_;
  SimulationOptions options_;
  double dt_s_;
  double time_s_ = 0;
  uint64_t steps_ = 0;
  std::unique_ptr<b2World> world_;
  b2Body* body_ = nullptr;
  double duty_[2] = {0, 0};
  double motor_speed_rad_s_[2] = {0, 0};  ///< at the wheel's scale (after the gearbox)
  double wheel_speed_rad_s_[2] = {0, 0};
  double wheel_angle_rad_[2] = {0, 0};
  double play_rad_[2] = {0, 0};  ///< where the motor stands in the gearbox's play, |.| <= backlash/2
  double slip_[2] = {0, 0};      ///< each wheel's slip: its contact moves by (1 - slip) x rim speed
  double next_slip_s_ = 0;
  std::mt19937_64 slip_rng_;
  double radius_m_[2];
  double gain_[2];
  /// A coasting wheel slower than this stops (the rest of its coast: 1/20 encoder tick) [rad/s].
  double stop_speed_rad_s_ = 0;
  double normal_load_n_[2];
  struct Stamped {
    double t_s;
    Pose2 pose;
  };
  std::deque<Stamped> history_;
  double unwrapped_yaw_rad_ = 0;
};

}  // namespace sim
}  // namespace autocal
