#include "autocal/odometry/dead_reckoning.h"

#include <cmath>

#include "autocal/errors.h"

namespace autocal {
namespace odometry {

DiffDriveParams DiffDriveParams::fromWheel(double wheel_diameter_m, double pulses_per_revolution,
                                           double wheelbase_m) {
  // Paper 002 §1.1: c_m = π·D_n/C_e, the same for both wheels when nothing is calibrated.
  DiffDriveParams p;
  p.left_m_per_pulse = M_PI * wheel_diameter_m / pulses_per_revolution;
  p.right_m_per_pulse = p.left_m_per_pulse;
  p.wheelbase_m = wheelbase_m;
  p.validate();
  return p;
}

void DiffDriveParams::validate() const {
  auto check = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw ConfigError(std::string(name) + " must be a finite positive number, got " +
                        std::to_string(v));
    }
  };
  check(left_m_per_pulse, "left_m_per_pulse");
  check(right_m_per_pulse, "right_m_per_pulse");
  check(wheelbase_m, "wheelbase_m");
}

DiffDriveParams applyUmbmarkCorrection(const DiffDriveParams& nominal, double Ed, double Eb) {
  if (!std::isfinite(Ed) || Ed <= 0.0) throw CalibrationError("Ed must be positive and finite");
  if (!std::isfinite(Eb) || Eb <= 0.0) throw CalibrationError("Eb must be positive and finite");
  DiffDriveParams p = nominal;
  p.left_m_per_pulse *= 2.0 / (Ed + 1.0);
  p.right_m_per_pulse *= 2.0 / (1.0 / Ed + 1.0);
  p.wheelbase_m *= Eb;
  return p;
}

Integrator integratorFromName(const std::string& name) {
  if (name == "euler") return Integrator::kEuler;
  if (name == "runge_kutta2") return Integrator::kRungeKutta2;
  if (name == "exact") return Integrator::kExact;
  throw ConfigError("integrator: expected euler, runge_kutta2 or exact, got '" + name + "'");
}

Pose2D integrateStep(const Pose2D& pose, double left_m, double right_m, double wheelbase_m,
                     Integrator integrator) {
  const double ds = 0.5 * (right_m + left_m);
  const double dtheta = (right_m - left_m) / wheelbase_m;
  Pose2D out = pose;
  out.yaw_rad = pose.yaw_rad + dtheta;
  switch (integrator) {
    case Integrator::kEuler:
      out.x_m += ds * std::cos(pose.yaw_rad);
      out.y_m += ds * std::sin(pose.yaw_rad);
      break;
    case Integrator::kRungeKutta2:
      out.x_m += ds * std::cos(pose.yaw_rad + 0.5 * dtheta);
      out.y_m += ds * std::sin(pose.yaw_rad + 0.5 * dtheta);
      break;
    case Integrator::kExact:
      // Constant wheel speeds over the step make the centre move on a circle of radius
      // ds/dθ. Written as chord·direction of the mid-step heading, with the chord factor
      // sin(dθ/2)/(dθ/2), which stays accurate as dθ → 0 (no division by a tiny dθ).
      {
        const double half = 0.5 * dtheta;
        const double chord_factor =
            std::abs(half) < 1e-6 ? 1.0 - half * half / 6.0 : std::sin(half) / half;
        out.x_m += ds * chord_factor * std::cos(pose.yaw_rad + half);
        out.y_m += ds * chord_factor * std::sin(pose.yaw_rad + half);
      }
      break;
  }
  return out;
}

DeadReckoning::DeadReckoning(const DiffDriveParams& params, Integrator integrator,
                             const Pose2D& start)
    : params_(params), integrator_(integrator), pose_(start) {
  params_.validate();
}

void DeadReckoning::addPulses(double left_pulses, double right_pulses) {
  const double left_m = left_pulses * params_.left_m_per_pulse;
  const double right_m = right_pulses * params_.right_m_per_pulse;
  pose_ = integrateStep(pose_, left_m, right_m, params_.wheelbase_m, integrator_);
  distance_m_ += std::abs(0.5 * (left_m + right_m));
}

void DeadReckoning::addTicks(std::int32_t left_ticks, std::int32_t right_ticks) {
  if (!have_ticks_) {
    have_ticks_ = true;
  } else {
    // Unsigned subtraction gives the right increment across a 32-bit wrap-around.
    const auto dl = static_cast<std::int32_t>(static_cast<std::uint32_t>(left_ticks) -
                                              static_cast<std::uint32_t>(last_left_ticks_));
    const auto dr = static_cast<std::int32_t>(static_cast<std::uint32_t>(right_ticks) -
                                              static_cast<std::uint32_t>(last_right_ticks_));
    addPulses(dl, dr);
  }
  last_left_ticks_ = left_ticks;
  last_right_ticks_ = right_ticks;
}

double wrapAngle(double angle_rad) {
  double a = std::fmod(angle_rad + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

}  // namespace odometry
}  // namespace autocal
