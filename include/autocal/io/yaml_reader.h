// A strict reader of YAML configuration: every key must be known, every value of the right type.
// Errors are ConfigError naming the file, the line and the full key ("robot.yaml:12: camera.fx:
// expected a number, got 'abc'"); unknown keys are reported the same way when the map is closed.
#pragma once

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

#include "autocal/errors.h"

namespace autocal {

class YamlMap {
 public:
  /// Reads `path`; throws ConfigError when it is missing, not YAML, or not a map at its top.
  static YamlMap loadFile(const std::string& path);
  /// Wraps a parsed node (for strings in tests); `file` names it in messages.
  static YamlMap fromString(const std::string& text, const std::string& file);

  YamlMap(const YAML::Node& node, std::string file, std::string prefix);

  bool has(const std::string& key) const;

  template <typename T>
  T required(const std::string& key);
  template <typename T>
  T optional(const std::string& key, const T& fallback);

  YamlMap map(const std::string& key);
  /// A required list of maps.
  std::vector<YamlMap> mapList(const std::string& key);
  /// An optional list of maps (empty when absent).
  std::vector<YamlMap> optionalMapList(const std::string& key);

  /// Throws ConfigError for the first key that no required()/optional()/map() call asked for.
  void finish() const;

  /// "file:line: key: message" for a key of this map (or the map itself when key is empty).
  [[noreturn]] void fail(const std::string& key, const std::string& message) const;

  const std::string& file() const { return file_; }
  std::string fullKey(const std::string& key) const;

 private:
  template <typename T>
  T convert(const std::string& key, const YAML::Node& value) const;
  YAML::Node child(const std::string& key);

  YAML::Node node_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> used_;
};

}  // namespace autocal
