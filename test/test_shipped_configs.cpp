// Every config the package ships loads with the loader that reads it: the simulator's robots and
// worlds (sim/config/**), the camera_info the lane refinement starts from, the camera stage's
// config and the UMBmark errors example (config/). A key renamed in a loader without its configs,
// or a config edited into an error, fails here and not in the middle of a run.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "autocal/camera/camera_config.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/odometry/umbmark.h"
#include "autocal/sim/config.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> shippedConfigs() {
  std::vector<std::string> out;
  for (const char* dir : {"sim/config", "config"}) {
    for (const auto& e : fs::recursive_directory_iterator(fs::path(AUTOCAL_SOURCE_DIR) / dir)) {
      if (e.path().extension() == ".yaml")
        out.push_back(fs::relative(e.path(), AUTOCAL_SOURCE_DIR).string());
    }
  }
  return out;
}

/// Loads the file with its loader, chosen by its name; false when no loader is known for it.
bool load(const std::string& rel) {
  const std::string path = std::string(AUTOCAL_SOURCE_DIR) + "/" + rel;
  const std::string name = fs::path(rel).filename().string();
  if (name.rfind("robot", 0) == 0) {
    autocal::sim::loadRobotConfig(path);
  } else if (name.rfind("world", 0) == 0) {
    autocal::sim::loadWorldConfig(path);
  } else if (name == "lane_camera_autobot.yaml") {
    autocal::loadCameraInfoYaml(path);
  } else if (name == "camera_calibration.yaml") {
    autocal::camera::loadCameraCalibrationConfig(path);
  } else if (name == "umbmark_errors_example.yaml") {
    std::vector<autocal::odometry::ReturnError> cw, ccw;
    autocal::odometry::loadUmbmarkErrors(path, &cw, &ccw);
  } else {
    return false;
  }
  return true;
}

class ShippedConfig : public testing::TestWithParam<std::string> {};

TEST_P(ShippedConfig, Loads) {
  bool known = false;
  EXPECT_NO_THROW(known = load(GetParam())) << GetParam();
  EXPECT_TRUE(known) << GetParam() << ": no loader is known for it; add one to load()";
}

INSTANTIATE_TEST_SUITE_P(All, ShippedConfig, testing::ValuesIn(shippedConfigs()),
                         [](const testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

TEST(ShippedConfigs, AllFound) { EXPECT_GE(shippedConfigs().size(), 15u); }

}  // namespace
