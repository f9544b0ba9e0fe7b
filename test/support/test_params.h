// A rostest's expected values and tolerances: private parameters set in its .test file.
#pragma once

#include <gtest/gtest.h>
#include <ros/node_handle.h>

#include <string>

namespace autocal {
namespace test {

/// ~name of the test node; a test failure (and a default value) when the .test file lacks it.
template <typename T>
T testParam(const std::string& name) {
  T value{};
  if (!ros::NodeHandle("~").getParam(name, value)) {
    ADD_FAILURE() << "the .test file does not set ~" << name;
  }
  return value;
}

}  // namespace test
}  // namespace autocal
