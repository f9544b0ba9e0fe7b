// Dead reckoning of a differential-drive robot from wheel-encoder pulses (paper 002 §1.1), with
// the wheel and wheelbase parameters that UMBmark and the UAH method calibrate.
#pragma once

#include <cstdint>
#include <string>

#include "autocal/pose2d.h"

namespace autocal {
namespace odometry {

/// An odometry stage's stop has settled after this long at the latest, whatever the encoders say
/// [s] (UahRun, UmbmarkRun and the UAH replay).
constexpr double kMaxSettleS = 3.0;

/// The kinematic parameters odometry needs: distance per encoder pulse of each wheel (paper
/// 002's c_L, c_R, here in metres) and the effective wheelbase b.
struct DiffDriveParams {
  double left_m_per_pulse = 0.0;
  double right_m_per_pulse = 0.0;
  double wheelbase_m = 0.0;

  /// Nominal parameters from a wheel diameter, encoder resolution and wheelbase.
  static DiffDriveParams fromWheel(double wheel_diameter_m, double pulses_per_revolution,
                                   double wheelbase_m);
  /// Throws ConfigError naming the first parameter that is not finite and positive.
  void validate() const;
};

/// Applies UMBmark's corrections (Borenstein & Feng 1996) to nominal parameters: the wheel
/// diameter ratio Ed = D_R/D_L is split so that the average diameter is unchanged,
/// c_L = 2/(Ed + 1), c_R = 2/(1/Ed + 1), and the wheelbase becomes Eb·b.
DiffDriveParams applyUmbmarkCorrection(const DiffDriveParams& nominal, double Ed, double Eb);

using autocal::Pose2D;

/// How one step of wheel travel becomes a pose change.
enum class Integrator {
  kEuler,        ///< move along the heading at the start of the step
  kRungeKutta2,  ///< move along the mid-step heading
  kExact,        ///< the step is a circular arc (both wheel speeds constant over the step)
};
/// "euler", "runge_kutta2" or "exact"; throws ConfigError otherwise.
Integrator integratorFromName(const std::string& name);

/// One step: the left and right wheels travelled `left_m` and `right_m` [m].
/// Paper 002 §1.1: ΔS = (ΔS_R + ΔS_L)/2, Δθ = (ΔS_R − ΔS_L)/b.
Pose2D integrateStep(const Pose2D& pose, double left_m, double right_m, double wheelbase_m,
                     Integrator integrator = Integrator::kExact);

/// Accumulates the pose from encoder pulses.
class DeadReckoning {
 public:
  explicit DeadReckoning(const DiffDriveParams& params, Integrator integrator = Integrator::kExact,
                         const Pose2D& start = Pose2D());

  /// Adds pulse increments of each wheel (fractional pulses allowed, for simulation).
  void addPulses(double left_pulses, double right_pulses);
  /// Adds cumulative encoder counts (WheelEncoderStamped.data); the first call only sets the
  /// reference. Counts are 32-bit and may wrap around.
  void addTicks(std::int32_t left_ticks, std::int32_t right_ticks);

  const Pose2D& pose() const { return pose_; }
  const DiffDriveParams& params() const { return params_; }
  /// Path length of the robot centre so far [m].
  double distance_m() const { return distance_m_; }

 private:
  DiffDriveParams params_;
  Integrator integrator_;
  Pose2D pose_;
  double distance_m_ = 0.0;
  bool have_ticks_ = false;
  std::int32_t last_left_ticks_ = 0;
  std::int32_t last_right_ticks_ = 0;
};

/// Wraps an angle to (−π, π].
double wrapAngle(double angle_rad);

}  // namespace odometry
}  // namespace autocal
