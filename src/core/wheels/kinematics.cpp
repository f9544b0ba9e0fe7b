#include "autocal/wheels/kinematics.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <sstream>
#include <utility>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {
namespace wheels {

namespace {

/// The first bad key of `p` and what is wrong with it; an empty key when all are good. Shared by
/// validate() and the file reader (which names the file and line too).
std::pair<std::string, std::string> firstProblem(const KinematicsParams& p) {
  for (const KinematicsField& f : kinematicsFields()) {
    if (!std::isfinite(p.*f.member)) return {f.key, "must be a finite number"};
  }
  const std::pair<const char*, double> positive[] = {
      {"gain", p.gain},   {"baseline", p.baseline}, {"radius", p.radius},      {"k", p.k},
      {"limit", p.limit}, {"v_max", p.v_max},       {"omega_max", p.omega_max}};
  for (const auto& kv : positive) {
    if (kv.second <= 0.0) return {kv.first, "must be > 0, got " + formatNumber(kv.second)};
  }
  if (std::abs(p.trim) >= p.gain) {
    // gain ± trim scales each wheel: at |trim| ≥ gain one wheel stops or turns backwards.
    return {"trim",
            "|trim| must be < gain (" + formatNumber(p.gain) + "), got " + formatNumber(p.trim)};
  }
  for (const auto& kv : {std::make_pair("deadband_left", p.deadband_left),
                         std::make_pair("deadband_right", p.deadband_right)}) {
    if (kv.second < 0.0 || kv.second >= 1.0) {
      return {kv.first, "must be within [0, 1), got " + formatNumber(kv.second)};
    }
  }
  return {"", ""};
}

double sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

/// The shortest text that reads back as exactly `value`, with a decimal point as Duckietown's
/// files have ("1.0", "0.0318").
std::string yamlNumber(double value) {
  std::string text;
  for (int digits = 6; digits <= 17; ++digits) {
    text = formatNumber(value, digits);
    if (std::stod(text) == value) break;
  }
  if (text.find_first_of(".eEni") == std::string::npos) text += ".0";
  return text;
}

}  // namespace

const std::vector<KinematicsField>& kinematicsFields() {
  static const std::vector<KinematicsField> fields{
      {"gain", &KinematicsParams::gain},
      {"trim", &KinematicsParams::trim},
      {"baseline", &KinematicsParams::baseline},
      {"radius", &KinematicsParams::radius},
      {"k", &KinematicsParams::k},
      {"limit", &KinematicsParams::limit},
      {"v_max", &KinematicsParams::v_max},
      {"omega_max", &KinematicsParams::omega_max},
      {"deadband_left", &KinematicsParams::deadband_left},
      {"deadband_right", &KinematicsParams::deadband_right}};
  return fields;
}

void KinematicsParams::validate() const {
  const auto problem = firstProblem(*this);
  if (!problem.first.empty()) throw ConfigError(problem.first + ": " + problem.second);
}

double compensateDeadband(double u, double offset) {
  if (u == 0.0) return 0.0;
  return sign(u) * (offset + (1.0 - offset) * std::abs(u));
}

double removeDeadband(double duty, double offset) {
  if (std::abs(duty) <= offset) return 0.0;
  return sign(duty) * (std::abs(duty) - offset) / (1.0 - offset);
}

WheelDuties speedsToDuties(const KinematicsParams& p, const WheelSpeeds& speeds) {
  // Duckietown: u = (gain ± trim)/k · ω, then ±limit (the deadband offsets are autocal's).
  const double u_r = (p.gain + p.trim) * speeds.right / p.k;
  const double u_l = (p.gain - p.trim) * speeds.left / p.k;
  WheelDuties d;
  d.right = std::clamp(compensateDeadband(u_r, p.deadband_right), -p.limit, p.limit);
  d.left = std::clamp(compensateDeadband(u_l, p.deadband_left), -p.limit, p.limit);
  return d;
}

WheelSpeeds dutiesToSpeeds(const KinematicsParams& p, const WheelDuties& duties) {
  WheelSpeeds s;
  s.right = removeDeadband(duties.right, p.deadband_right) * p.k / (p.gain + p.trim);
  s.left = removeDeadband(duties.left, p.deadband_left) * p.k / (p.gain - p.trim);
  return s;
}

WheelDuties carCmdToDuties(const KinematicsParams& p, double v_mps, double omega_radps) {
  const double v = std::clamp(v_mps, -p.v_max, p.v_max);
  const double omega = std::clamp(omega_radps, -p.omega_max, p.omega_max);
  WheelSpeeds speeds;
  speeds.right = (v + 0.5 * omega * p.baseline) / p.radius;
  speeds.left = (v - 0.5 * omega * p.baseline) / p.radius;
  return speedsToDuties(p, speeds);
}

double speedRatioFromTrim(double trim, double gain) {
  if (!(gain > 0.0) || !std::isfinite(gain)) {
    throw ConfigError("gain: must be > 0, got " + formatNumber(gain));
  }
  if (!(std::abs(trim) < gain)) {
    throw ConfigError("trim: |trim| must be < gain (" + formatNumber(gain) + "), got " +
                      formatNumber(trim));
  }
  return (gain + trim) / (gain - trim);
}

double trimFromSpeedRatio(double ratio, double gain) {
  if (!(gain > 0.0) || !std::isfinite(gain)) {
    throw ConfigError("gain: must be > 0, got " + formatNumber(gain));
  }
  if (!(ratio > 0.0) || !std::isfinite(ratio)) {
    throw InputError("wheel speed ratio must be a positive number, got " + formatNumber(ratio));
  }
  return gain * (ratio - 1.0) / (ratio + 1.0);
}

std::string kinematicsPath(const std::string& calibration_root, const std::string& vehicle) {
  if (vehicle.empty() || vehicle.find('/') != std::string::npos) {
    throw ConfigError("vehicle name must be a non-empty name without '/', got '" + vehicle + "'");
  }
  if (calibration_root.empty()) throw ConfigError("calibration_root must not be empty");
  return calibration_root + "/kinematics/" + vehicle + ".yaml";
}

KinematicsParams readKinematicsFile(const std::string& path) {
  YamlMap map = YamlMap::fromString(readFile(path), path);
  KinematicsParams p;
  map.optional<std::string>("calibration_time", "");  // informative only
  for (const KinematicsField& f : kinematicsFields()) {
    p.*f.member = map.optional<double>(f.key, p.*f.member);
  }
  map.finish();
  const auto problem = firstProblem(p);
  if (!problem.first.empty()) map.fail(problem.first, problem.second);
  return p;
}

KinematicsParams readKinematicsFileOrDefaults(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec) && !ec) return KinematicsParams();
  return readKinematicsFile(path);
}

std::string kinematicsYaml(const KinematicsParams& params, const std::string& time_utc) {
  std::ostringstream out;
  out << "calibration_time: " << time_utc << "\n";
  for (const KinematicsField& f : kinematicsFields()) {
    out << f.key << ": " << yamlNumber(params.*f.member) << "\n";
  }
  return out.str();
}

std::string writeKinematicsFile(const std::string& path, const KinematicsParams& params) {
  params.validate();  // before anything touches the file
  const std::string time_utc = kinematicsTimeUtcNow();
  writeFileAtomically(path, kinematicsYaml(params, time_utc));
  return time_utc;
}

std::string kinematicsTimeUtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d-%H-%M-%S", &tm);
  return buf;
}

}  // namespace wheels
}  // namespace autocal
