#include "autocal/io/yaml_reader.h"

#include <cmath>
#include <sstream>

#include "autocal/io/type_names.h"

namespace autocal {

namespace {
std::string where(const std::string& file, const YAML::Node& node) {
  std::ostringstream ss;
  ss << file;
  if (node.IsDefined() && node.Mark().line >= 0) ss << ":" << node.Mark().line + 1;
  return ss.str();
}

}  // namespace

YamlMap YamlMap::loadFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) throw ConfigError(path + ": expected a map of keys at the top of the file");
  return YamlMap(root, path, "");
}

YamlMap YamlMap::fromString(const std::string& text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(file + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) throw ConfigError(file + ": expected a map of keys at the top");
  return YamlMap(root, file, "");
}

YamlMap::YamlMap(const YAML::Node& node, std::string file, std::string prefix)
    : node_(node), file_(std::move(file)), prefix_(std::move(prefix)) {}

std::string YamlMap::fullKey(const std::string& key) const {
  if (prefix_.empty()) return key;
  if (key.empty()) return prefix_;
  return prefix_ + "." + key;
}

void YamlMap::fail(const std::string& key, const std::string& message) const {
  const YAML::Node at = key.empty() ? node_ : node_[key];
  throw ConfigError(where(file_, at.IsDefined() ? at : node_) + ": " + fullKey(key) + ": " +
                    message);
}

bool YamlMap::has(const std::string& key) const { return node_[key].IsDefined(); }

YAML::Node YamlMap::child(const std::string& key) {
  used_.insert(key);
  return node_[key];
}

template <typename T>
T YamlMap::convert(const std::string& key, const YAML::Node& value) const {
  try {
    if constexpr (std::is_same_v<T, std::vector<double>>) {
      if (!value.IsSequence()) throw YAML::Exception(value.Mark(), "");
      std::vector<double> out;
      for (size_t i = 0; i < value.size(); ++i) {
        out.push_back(convert<double>(key + "[" + std::to_string(i) + "]", value[i]));
      }
      return out;
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      if (!value.IsSequence()) throw YAML::Exception(value.Mark(), "");
      std::vector<std::string> out;
      for (size_t i = 0; i < value.size(); ++i) {
        out.push_back(convert<std::string>(key + "[" + std::to_string(i) + "]", value[i]));
      }
      return out;
    } else if constexpr (std::is_same_v<T, std::vector<std::vector<double>>>) {
      if (!value.IsSequence()) throw YAML::Exception(value.Mark(), "");
      std::vector<std::vector<double>> out;
      for (size_t i = 0; i < value.size(); ++i) {
        out.push_back(convert<std::vector<double>>(key + "[" + std::to_string(i) + "]", value[i]));
      }
      return out;
    } else {
      if (!value.IsScalar()) throw YAML::Exception(value.Mark(), "");
      const T v = value.as<T>();
      if constexpr (std::is_same_v<T, double>) {
        if (!std::isfinite(v)) fail(key, "must be a finite number");
      }
      return v;
    }
  } catch (const YAML::Exception&) {
    std::string got =
        value.IsScalar() ? "'" + value.Scalar() + "'" : (value.IsSequence() ? "a list" : "a map");
    fail(key, std::string("expected ") + expectedTypeName<T>() + ", got " + got);
  }
}

template <typename T>
T YamlMap::required(const std::string& key) {
  const YAML::Node value = child(key);
  if (!value.IsDefined() || value.IsNull()) {
    throw ConfigError(where(file_, node_) + ": " + fullKey(key) + ": required key is missing");
  }
  return convert<T>(key, value);
}

template <typename T>
T YamlMap::optional(const std::string& key, const T& fallback) {
  const YAML::Node value = child(key);
  if (!value.IsDefined() || value.IsNull()) return fallback;
  return convert<T>(key, value);
}

YamlMap YamlMap::map(const std::string& key) {
  const YAML::Node value = child(key);
  if (!value.IsDefined()) {
    throw ConfigError(where(file_, node_) + ": " + fullKey(key) + ": required map is missing");
  }
  if (!value.IsMap()) fail(key, "expected a map of keys");
  return YamlMap(value, file_, fullKey(key));
}

std::vector<YamlMap> YamlMap::mapList(const std::string& key) {
  if (!has(key)) {
    throw ConfigError(where(file_, node_) + ": " + fullKey(key) + ": required list is missing");
  }
  return optionalMapList(key);
}

std::vector<YamlMap> YamlMap::optionalMapList(const std::string& key) {
  const YAML::Node value = child(key);
  std::vector<YamlMap> out;
  if (!value.IsDefined() || value.IsNull()) return out;
  if (!value.IsSequence()) fail(key, "expected a list");
  for (size_t i = 0; i < value.size(); ++i) {
    const std::string item_key = fullKey(key) + "[" + std::to_string(i) + "]";
    if (!value[i].IsMap()) {
      throw ConfigError(where(file_, value[i]) + ": " + item_key + ": expected a map of keys");
    }
    out.emplace_back(value[i], file_, item_key);
  }
  return out;
}

void YamlMap::finish() const {
  for (const auto& kv : node_) {
    const std::string key = kv.first.as<std::string>();
    if (!used_.count(key)) {
      throw ConfigError(where(file_, kv.first) + ": " + fullKey(key) + ": unknown key");
    }
  }
}

template double YamlMap::required<double>(const std::string&);
template int YamlMap::required<int>(const std::string&);
template bool YamlMap::required<bool>(const std::string&);
template std::string YamlMap::required<std::string>(const std::string&);
template std::vector<double> YamlMap::required<std::vector<double>>(const std::string&);
template std::vector<std::string> YamlMap::required<std::vector<std::string>>(const std::string&);
template double YamlMap::optional<double>(const std::string&, const double&);
template int YamlMap::optional<int>(const std::string&, const int&);
template bool YamlMap::optional<bool>(const std::string&, const bool&);
template std::string YamlMap::optional<std::string>(const std::string&, const std::string&);
template std::vector<double> YamlMap::optional<std::vector<double>>(const std::string&,
                                                                    const std::vector<double>&);
template std::vector<std::vector<double>> YamlMap::required<std::vector<std::vector<double>>>(
    const std::string&);

}  // namespace autocal
