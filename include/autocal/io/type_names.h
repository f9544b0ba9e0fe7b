// How a parameter's expected type is named in error messages, the same for YAML files and ROS
// parameters ("~rate_hz: expected a number").
#pragma once

#include <string>
#include <type_traits>
#include <vector>

namespace autocal {

template <typename T>
constexpr const char* expectedTypeName() {
  if constexpr (std::is_same_v<T, double>) return "a number";
  if constexpr (std::is_same_v<T, int>) return "an integer";
  if constexpr (std::is_same_v<T, bool>) return "true or false";
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  if constexpr (std::is_same_v<T, std::vector<double>>) return "a list of numbers";
  if constexpr (std::is_same_v<T, std::vector<std::string>>) return "a list of strings";
  if constexpr (std::is_same_v<T, std::vector<std::vector<double>>>) {
    return "a list of lists of numbers";
  }
  return "a value of another type";
}

}  // namespace autocal
