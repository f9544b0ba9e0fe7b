// One way for every node to read its private parameters into the core's options struct: each
// value is echoed once at INFO (with "(default)" when it was not set), a value of the wrong type
// is a ConfigError naming "~key", and a missing required one fails loudly.
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "autocal/errors.h"
#include "autocal/physical_range.h"

namespace autocal {
namespace ros_layer {

/// The robot's name when ~veh is not set: the last component of the node's namespace ("autobot"
/// in the root namespace).
std::string defaultVeh(const ros::NodeHandle& nh);

/// Throws ConfigError "~<key>: <what>" unless `ok`: a node's options name the private parameter.
void checkParam(bool ok, const std::string& key, const std::string& what);

/// A length parameter [m] a robot of this size can have: a ConfigError "~key VALUE: <what> ... is
/// MIN-MAX m; VALUE looks like millimetres (...)" when it is off (outOfRange). Zero and negative
/// values are left to the parameter's own check.
void checkLength(const std::string& key, double value_m, const PhysicalRange& range);

/// ~calibration_root as a node needs it: not empty and absolute (a node runs in $ROS_HOME, where a
/// relative path would put the files); a ConfigError saying how to give it otherwise.
void checkCalibrationRoot(const std::string& calibration_root);

/// Runs a core options struct's validate() for a node: its ConfigError "key: what" becomes
/// "~key: what", the private parameter's name.
template <class Options>
void validateParams(const Options& options) {
  try {
    options.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("~") + e.what());
  }
}

class ParamReader {
 public:
  /// `pnh` is the node's private handle; `node_name` prefixes the echoed lines.
  ParamReader(const ros::NodeHandle& pnh, std::string node_name);

  /// Reads ~name into `value` when it is set; otherwise keeps `value` (the documented default).
  void get(const std::string& name, double& value) const;
  void get(const std::string& name, int& value) const;
  void get(const std::string& name, bool& value) const;
  void get(const std::string& name, std::string& value) const;
  void get(const std::string& name, std::vector<double>& value) const;

  /// Reads ~name; throws ConfigError "~name: required parameter is missing" when it is not set.
  void require(const std::string& name, double& value) const;
  void require(const std::string& name, int& value) const;
  void require(const std::string& name, bool& value) const;
  void require(const std::string& name, std::string& value) const;

 private:
  template <typename T>
  void read(const std::string& name, T& value, bool required) const;

  ros::NodeHandle pnh_;
  std::string node_name_;
};

}  // namespace ros_layer
}  // namespace autocal
