// The odometry calibration file: contents, multipliers, and the quality gate that keeps a failed
// result from replacing a good file.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/odometry/calibration_file.h"

namespace fs = std::filesystem;
using namespace autocal::odometry;

namespace {

OdometryCalibration sample() {
  OdometryCalibration c;
  c.method = "uah";
  c.vehicle = "bot";
  c.Ed = 1.002;
  c.Eb = 1.03;
  c.wheelbase_nominal_m = 0.1;
  c.wheelbase_m = 0.103;
  c.left_pulse_factor = 0.999;
  c.right_pulse_factor = 1.001;
  c.left_m_per_pulse = 0.0015;
  c.right_m_per_pulse = 0.0016;
  c.inputs = {{"rounds", "5"}, {"note", "'a b'"}};
  return c;
}

TEST(OdometryCalibrationFile, YamlHoldsEverythingAndMultipliers) {
  const YAML::Node y = YAML::Load(odometryCalibrationYaml(sample(), "1999-01-01T00:00:00Z"));
  EXPECT_EQ(y["method"].as<std::string>(), "uah");
  EXPECT_DOUBLE_EQ(y["Ed"].as<double>(), 1.002);
  EXPECT_DOUBLE_EQ(y["b"].as<double>(), 0.103);
  EXPECT_DOUBLE_EQ(y["left_m_per_pulse"].as<double>(), 0.0015);
  EXPECT_DOUBLE_EQ(y["left_wheel_radius_multiplier"].as<double>(), 0.999);
  EXPECT_NEAR(y["wheel_separation_multiplier"].as<double>(), 1.03, 1e-12);
  EXPECT_EQ(y["inputs"]["rounds"].as<int>(), 5);
  EXPECT_EQ(y["inputs"]["note"].as<std::string>(), "a b");
  EXPECT_EQ(y["date"].as<std::string>(), "1999-01-01T00:00:00Z");
}

TEST(OdometryCalibrationFile, FailedResultNeverReplacesAGoodFile) {
  const fs::path dir = fs::temp_directory_path() / ("autocal_odo_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string path = odometryCalibrationPath(dir.string(), "bot");
  EXPECT_EQ(path, dir.string() + "/odometry/bot.yaml");
  writeOdometryCalibration(path, sample());
  const std::string good = autocal::readFile(path);
  for (double Ed : {0.0, 1.5, double(NAN)}) {
    OdometryCalibration bad = sample();
    bad.Ed = Ed;
    EXPECT_THROW(writeOdometryCalibration(path, bad), autocal::CalibrationError);
    EXPECT_EQ(autocal::readFile(path), good);
  }
  OdometryCalibration bad = sample();
  bad.wheelbase_m = -1;
  EXPECT_THROW(writeOdometryCalibration(path, bad), autocal::CalibrationError);
  EXPECT_EQ(autocal::readFile(path), good);
  writeOdometryCalibration(path, sample());
  EXPECT_TRUE(fs::exists(path + ".prev"));
  EXPECT_THROW(odometryCalibrationPath("x", "a/b"), autocal::ConfigError);
  fs::remove_all(dir);
}

}  // namespace
