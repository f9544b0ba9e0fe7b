#include "autocal_ros/params.h"

#include <ros/console.h>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/type_names.h"

namespace autocal {
namespace ros_layer {

std::string defaultVeh(const ros::NodeHandle& nh) {
  std::string ns = nh.getNamespace();
  while (!ns.empty() && ns.back() == '/') ns.pop_back();
  const size_t slash = ns.rfind('/');
  const std::string last = slash == std::string::npos ? ns : ns.substr(slash + 1);
  return last.empty() ? "autobot" : last;
}
void checkParam(bool ok, const std::string& key, const std::string& what) {
  checkConfig(ok, "~" + key, what);
}

void checkLength(const std::string& key, double value_m, const PhysicalRange& range) {
  const std::string slip = outOfRange("~" + key, value_m, range);
  if (!slip.empty()) throw ConfigError(slip);
}

void checkCalibrationRoot(const std::string& calibration_root) {
  checkParam(!calibration_root.empty(), "calibration_root", "must not be empty");
  checkParam(calibration_root.front() == '/', "calibration_root",
             "'" + calibration_root +
                 "' is a relative path: the nodes run in $ROS_HOME (~/.ros), where it would put "
                 "the files; give an absolute one, e.g. calibration_root:=$(env PWD)/" +
                 calibration_root +
                 " in a launch file, or use rosrun autocal calibrate_sim, "
                 "which resolves it from the current folder");
}

namespace {
std::string show(double v) { return formatNumber(v); }
std::string show(int v) { return std::to_string(v); }
std::string show(bool v) { return v ? "true" : "false"; }
std::string show(const std::string& v) { return "'" + v + "'"; }
std::string show(const std::vector<double>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + formatNumber(v[i]);
  return s + "]";
}

}  // namespace

ParamReader::ParamReader(const ros::NodeHandle& pnh, std::string node_name)
    : pnh_(pnh), node_name_(std::move(node_name)) {}

template <typename T>
void ParamReader::read(const std::string& name, T& value, bool required) const {
  const std::string key = "~" + name;
  if (!pnh_.hasParam(name)) {
    if (required) {
      throw ConfigError(key + ": required parameter is missing (" + pnh_.resolveName(name) + ")");
    }
    ROS_INFO_STREAM(node_name_ << ": " << key << " = " << show(value) << " (default)");
    return;
  }
  T read_value{};
  if (!pnh_.getParam(name, read_value)) {
    throw ConfigError(key + ": expected " + expectedTypeName<T>() + " (" + pnh_.resolveName(name) +
                      ")");
  }
  if constexpr (std::is_same_v<T, double>) {
    if (!std::isfinite(read_value)) throw ConfigError(key + ": must be a finite number");
  }
  if constexpr (std::is_same_v<T, std::vector<double>>) {
    for (double x : read_value)
      if (!std::isfinite(x)) throw ConfigError(key + ": every element must be a finite number");
  }
  value = read_value;
  ROS_INFO_STREAM(node_name_ << ": " << key << " = " << show(value));
}

void ParamReader::get(const std::string& name, double& value) const { read(name, value, false); }
void ParamReader::get(const std::string& name, int& value) const { read(name, value, false); }
void ParamReader::get(const std::string& name, bool& value) const { read(name, value, false); }
void ParamReader::get(const std::string& name, std::string& value) const {
  read(name, value, false);
}
void ParamReader::get(const std::string& name, std::vector<double>& value) const {
  read(name, value, false);
}
void ParamReader::require(const std::string& name, double& value) const { read(name, value, true); }
void ParamReader::require(const std::string& name, int& value) const { read(name, value, true); }
void ParamReader::require(const std::string& name, bool& value) const { read(name, value, true); }
void ParamReader::require(const std::string& name, std::string& value) const {
  read(name, value, true);
}

}  // namespace ros_layer
}  // namespace autocal
