#include "autocal/odometry/calibration_file.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <ctime>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"

namespace autocal {
namespace odometry {

DiffDriveMultipliers OdometryCalibration::multipliers() const {
  // diff_drive_controller scales each nominal wheel radius and the separation: a wheel's
  // distance per pulse is proportional to its radius, so the factors are the multipliers.
  DiffDriveMultipliers m;
  m.left_wheel_radius_multiplier = left_pulse_factor;
  m.right_wheel_radius_multiplier = right_pulse_factor;
  m.wheel_separation_multiplier = wheelbase_m / wheelbase_nominal_m;
  return m;
}

void checkOdometryCalibration(const OdometryCalibration& c) {
  auto fail = [](const std::string& what) {
    throw CalibrationError("odometry calibration failed its quality gate: " + what);
  };
  auto positive = [&](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) fail(std::string(name) + " is not a positive number");
  };
  if (c.method.empty()) fail("no method");
  positive(c.Ed, "Ed");
  positive(c.Eb, "Eb");
  positive(c.wheelbase_nominal_m, "wheelbase_nominal_m");
  positive(c.wheelbase_m, "wheelbase_m");
  positive(c.left_pulse_factor, "c_L");
  positive(c.right_pulse_factor, "c_R");
  if (c.Ed < 0.8 || c.Ed > 1.25) {
    fail("Ed = " + std::to_string(c.Ed) +
         " is outside [0.8, 1.25] (wheels differing by more "
         "than 20 % are a measurement or unit error)");
  }
  if (c.Eb < 0.5 || c.Eb > 2.0) fail("Eb = " + std::to_string(c.Eb) + " is outside [0.5, 2]");
  if (!std::isfinite(c.left_m_per_pulse) || !std::isfinite(c.right_m_per_pulse) ||
      c.left_m_per_pulse < 0.0 || c.right_m_per_pulse < 0.0) {
    fail("distance per pulse is not a non-negative number");
  }
}

std::string odometryCalibrationYaml(const OdometryCalibration& c, const std::string& date_utc) {
  const DiffDriveMultipliers m = c.multipliers();
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  out << YAML::Key << "method" << YAML::Value << c.method;
  if (!c.expressions.empty()) out << YAML::Key << "expressions" << YAML::Value << c.expressions;
  out << YAML::Key << "vehicle" << YAML::Value << c.vehicle;
  out << YAML::Key << "date" << YAML::Value << date_utc;
  out << YAML::Key << "Ed" << YAML::Value << c.Ed;
  out << YAML::Key << "Eb" << YAML::Value << c.Eb;
  out << YAML::Key << "b" << YAML::Value << c.wheelbase_m;
  out << YAML::Key << "b_nominal" << YAML::Value << c.wheelbase_nominal_m;
  out << YAML::Key << "c_L" << YAML::Value << c.left_pulse_factor;
  out << YAML::Key << "c_R" << YAML::Value << c.right_pulse_factor;
  if (c.left_m_per_pulse > 0.0) {
    out << YAML::Key << "left_m_per_pulse" << YAML::Value << c.left_m_per_pulse;
    out << YAML::Key << "right_m_per_pulse" << YAML::Value << c.right_m_per_pulse;
  }
  out << YAML::Key << "left_wheel_radius_multiplier" << YAML::Value
      << m.left_wheel_radius_multiplier;
  out << YAML::Key << "right_wheel_radius_multiplier" << YAML::Value
      << m.right_wheel_radius_multiplier;
  out << YAML::Key << "wheel_separation_multiplier" << YAML::Value << m.wheel_separation_multiplier;
  out << YAML::Key << "inputs" << YAML::Value << YAML::BeginMap;
  for (const auto& kv : c.inputs) {
    out << YAML::Key << kv.first << YAML::Value;
    try {
      out << YAML::Load(kv.second);
    } catch (const YAML::Exception&) {
      out << kv.second;
    }
  }
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::string odometryCalibrationPath(const std::string& calibrations_root,
                                    const std::string& vehicle) {
  if (vehicle.empty() || vehicle.find('/') != std::string::npos) {
    throw ConfigError("vehicle name must be a non-empty name without '/', got '" + vehicle + "'");
  }
  return calibrations_root + "/odometry/" + vehicle + ".yaml";
}

void writeOdometryCalibration(const std::string& path, const OdometryCalibration& calibration) {
  checkOdometryCalibration(calibration);  // before anything touches the file
  writeFileAtomically(path, odometryCalibrationYaml(calibration, utcNowIso8601()));
}

}  // namespace odometry
}  // namespace autocal
