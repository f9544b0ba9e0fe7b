// A run whose simulator fails on its robot config (run_bad_config.test): the run's report names the
// config's file and key as the failure, not "interrupted".
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <filesystem>
#include <string>

#include "autocal/io/yaml_reader.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::test::spinUntil;
using autocal::test::testParam;
namespace fs = std::filesystem;

TEST(RunBadConfig, TheReportNamesTheConfigsFileAndKey) {
  const std::string veh = testParam<std::string>("veh");
  const fs::path summary =
      fs::path(testParam<std::string>("calibration_root")) / "report" / veh / "summary.yaml";
  ros::NodeHandle nh;
  ASSERT_TRUE(spinUntil([&] { return fs::exists(summary); }, 60.0)) << summary;
  // Written atomically: once it exists it is whole.
  autocal::YamlMap s = autocal::YamlMap::loadFile(summary.string());
  EXPECT_EQ(s.required<std::string>("result"), "failed");
  const std::string failure = s.required<std::string>("failure");
  std::cout << "failure: " << failure << std::endl;
  EXPECT_NE(failure.find("the simulator failed"), std::string::npos) << failure;
  EXPECT_NE(failure.find("robot_bad_key.yaml"), std::string::npos) << failure;
  EXPECT_NE(failure.find("wheel_radius_left"), std::string::npos) << failure;
  EXPECT_EQ(failure.find("interrupted"), std::string::npos) << failure;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_run_bad_config");
  return RUN_ALL_TESTS();
}
