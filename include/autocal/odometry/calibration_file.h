// The odometry calibration result every method produces, and the one function that writes it to
// `odometry/<veh>.yaml` (doc/files.md "Odometry").
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace autocal {
namespace odometry {

/// What ros_controllers' diff_drive_controller reads to correct its nominal model.
struct DiffDriveMultipliers {
  double left_wheel_radius_multiplier = 1.0;
  double right_wheel_radius_multiplier = 1.0;
  double wheel_separation_multiplier = 1.0;
};

struct OdometryCalibration {
  std::string method;       ///< "umbmark" or "uah"
  std::string expressions;  ///< UMBmark: "original" or "corrected"; empty otherwise
  std::string vehicle;      ///< <veh>
  double Ed = 1.0;          ///< D_R/D_L
  double Eb = 1.0;          ///< b_actual/b_nominal
  double wheelbase_nominal_m = 0.0;
  double wheelbase_m = 0.0;         ///< calibrated effective wheelbase b
  double left_pulse_factor = 1.0;   ///< left distance per pulse, as a factor of the nominal one
  double right_pulse_factor = 1.0;  ///< right distance per pulse, as a factor of the nominal one
  /// Absolute distances per pulse [m] when the method measures them (UAH); 0 when unknown.
  double left_m_per_pulse = 0.0;
  double right_m_per_pulse = 0.0;
  /// What the result was computed from, as (key, YAML flow value) pairs.
  std::vector<std::pair<std::string, std::string>> inputs;

  DiffDriveMultipliers multipliers() const;
};

/// The quality gate a result must pass before it may replace a file: finite values, Ed within
/// [0.8, 1.25], Eb within [0.5, 2], positive wheelbase and factors. Throws CalibrationError.
void checkOdometryCalibration(const OdometryCalibration& calibration);

/// The file's YAML text; `date_utc` is an ISO 8601 time.
std::string odometryCalibrationYaml(const OdometryCalibration& calibration,
                                    const std::string& date_utc);

/// `<calibrations_root>/odometry/<veh>.yaml`.
std::string odometryCalibrationPath(const std::string& calibrations_root,
                                    const std::string& vehicle);

/// Checks the result (checkOdometryCalibration) and only then writes it atomically to `path`,
/// keeping the previous file as `<path>.prev`. A failing result never touches the file.
/// Used by every command that calibrates odometry.
void writeOdometryCalibration(const std::string& path, const OdometryCalibration& calibration);

}  // namespace odometry
}  // namespace autocal
