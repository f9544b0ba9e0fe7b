// Duckietown's inverse kinematics and what its `gain` and `trim` mean, in wheel speeds and duties
// (DESIGN.md "Calibration files"), with an optional per-wheel deadband compensation, and the one
// reader and writer of `kinematics/<veh>.yaml`.
//
//   u_r = (gain + trim)(v + ω·baseline/2)/(radius·k)
//   u_l = (gain − trim)(v − ω·baseline/2)/(radius·k)
//
// each clipped to ±limit. u is a duty when the deadband offsets are 0 (Duckietown's semantics,
// exact). A motor with a deadband does not turn below a duty o and then speeds up linearly, so a
// multiplicative trim is right at one speed only; with the offsets set, the duty sent is
// d = sign(u)·(o + (1 − o)·|u|) for u ≠ 0, which makes the wheel speed proportional to u again, and
// one trim is right at every speed.
#pragma once

#include <string>
#include <vector>

#include "autocal/sensors.h"

namespace autocal {
namespace wheels {

/// The kinematics node's parameters, also the contents of `kinematics/<veh>.yaml`. Defaults are
/// Duckietown's (DESIGN.md).
struct KinematicsParams {
  double gain = 1.0;       ///< overall duty scale [1]
  double trim = 0.0;       ///< right − left balance [1]: > 0 speeds the right wheel up
  double baseline = 0.1;   ///< distance between the wheels [m]
  double radius = 0.0318;  ///< wheel radius [m]
  double k = 27.0;         ///< motor constant: wheel speed at duty 1 [rad/s]
  double limit = 1.0;      ///< duty magnitude limit [1]
  double v_max = 1.0;      ///< linear speed limit [m/s]
  double omega_max = 8.0;  ///< angular speed limit [rad/s]
  /// Deadband compensation (autocal's extra keys; 0 = off, Duckietown's semantics): the duty
  /// below which each motor does not turn [1], 0 ≤ o < 1.
  double deadband_left = 0.0;
  double deadband_right = 0.0;

  /// Throws ConfigError naming the first bad key (non-finite, radius/baseline/k/limit/v_max/
  /// omega_max ≤ 0, gain ≤ 0, |trim| ≥ gain, deadband outside [0, 1)).
  void validate() const;
};

/// The numeric keys of the file and of the node's parameters, in Duckietown's order, then the
/// deadband keys, each with the member it sets (one list for the reader, the writer and the node).
struct KinematicsField {
  const char* key;
  double KinematicsParams::*member;
};
const std::vector<KinematicsField>& kinematicsFields();

/// A car command (Duckietown's Twist2DStamped without the header).
struct CarCommand {
  double v_mps = 0.0;        ///< forward speed [m/s]
  double omega_radps = 0.0;  ///< turn rate [rad/s], > 0 counter-clockwise
};

/// Wheel speeds [rad/s] (positive = forward).
struct WheelSpeeds {
  double left = 0.0;
  double right = 0.0;
};

/// v [m/s] and ω [rad/s] clamped to ±v_max and ±omega_max, then Duckietown's inverse kinematics,
/// the deadband compensation and the ±limit clip.
WheelDuties carCmdToDuties(const KinematicsParams& params, double v_mps, double omega_radps);
inline WheelDuties carCmdToDuties(const KinematicsParams& params, const CarCommand& cmd) {
  return carCmdToDuties(params, cmd.v_mps, cmd.omega_radps);
}

/// The duties that make the NOMINAL wheel speeds `speeds` under `params` (no v/ω limits; ±limit
/// clip): u_r = (gain + trim)·ω_r/k, u_l = (gain − trim)·ω_l/k, then the deadband compensation.
WheelDuties speedsToDuties(const KinematicsParams& params, const WheelSpeeds& speeds);

/// The inverse of speedsToDuties (without the clip): the nominal wheel speeds these duties mean.
/// A duty inside a wheel's deadband means speed 0.
WheelSpeeds dutiesToSpeeds(const KinematicsParams& params, const WheelDuties& duties);

/// One duty through the deadband compensation: sign(u)·(o + (1 − o)·|u|) for u ≠ 0, 0 for u = 0.
double compensateDeadband(double u, double offset);
/// Its inverse: 0 inside the deadband (|d| ≤ o), else sign(d)·(|d| − o)/(1 − o).
double removeDeadband(double duty, double offset);

/// The wheel-speed ratio a trim makes at equal commanded speeds: right/left = (gain + trim)/(gain −
/// trim). Throws ConfigError unless gain > 0 and |trim| < gain.
double speedRatioFromTrim(double trim, double gain);
/// Its inverse: the trim that makes right/left = ratio: trim = gain·(ratio − 1)/(ratio + 1).
/// Throws InputError for a ratio that is not a positive finite number, ConfigError for gain ≤ 0.
double trimFromSpeedRatio(double ratio, double gain);

/// `<calibration_root>/kinematics/<veh>.yaml`.
std::string kinematicsPath(const std::string& calibration_root, const std::string& vehicle);

/// Reads the file: Duckietown's keys (`calibration_time` is read and ignored, a missing key keeps
/// its default) plus `deadband_left`/`deadband_right`; unknown keys and bad values are ConfigError
/// naming the file and key; a file that cannot be read is IoError. Validated.
KinematicsParams readKinematicsFile(const std::string& path);
/// The defaults when `path` does not exist, else readKinematicsFile(path) (a malformed file is an
/// error, never silently the defaults).
KinematicsParams readKinematicsFileOrDefaults(const std::string& path);

/// The file's YAML text, Duckietown's keys in Duckietown's order, `calibration_time` = `time_utc`
/// (YYYY-MM-DD-hh-mm-ss, as Duckietown writes it), then the deadband keys.
std::string kinematicsYaml(const KinematicsParams& params, const std::string& time_utc);

/// Validates, then writes atomically (previous file kept as `<path>.prev`). Returns the time
/// written. A failed validation (ConfigError) never touches the file; a failed write is IoError.
std::string writeKinematicsFile(const std::string& path, const KinematicsParams& params);

/// The current UTC time as Duckietown's `calibration_time` ("%Y-%m-%d-%H-%M-%S").
std::string kinematicsTimeUtcNow();

}  // namespace wheels
}  // namespace autocal
