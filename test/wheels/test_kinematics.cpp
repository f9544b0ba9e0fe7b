// Duckietown's inverse kinematics against its closed form, the deadband compensation, the trim as
// a speed ratio, and the kinematics file (round trip, defaults, malformed files, atomic writes).
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/wheels/kinematics.h"

namespace fs = std::filesystem;
using namespace autocal;
using namespace autocal::wheels;

namespace {

constexpr double kTol = 1e-12;

/// Duckietown's formula, written out here independently of the implementation.
double closedFormRight(double gain, double trim, double v, double w, double b = 0.1,
                       double r = 0.0318, double k = 27.0) {
  return (gain + trim) * (v + w * b / 2) / (r * k);
}
double closedFormLeft(double gain, double trim, double v, double w, double b = 0.1,
                      double r = 0.0318, double k = 27.0) {
  return (gain - trim) * (v - w * b / 2) / (r * k);
}

std::string messageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError";
  return "";
}

class KinematicsFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("autocal_kin_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    fs::create_directories(dir_);
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  fs::path dir_;
};

}  // namespace

TEST(Kinematics, DefaultsAreDuckietownsAndValid) {
  const KinematicsParams p;
  EXPECT_EQ(p.gain, 1.0);
  EXPECT_EQ(p.trim, 0.0);
  EXPECT_EQ(p.baseline, 0.1);
  EXPECT_EQ(p.radius, 0.0318);
  EXPECT_EQ(p.k, 27.0);
  EXPECT_EQ(p.limit, 1.0);
  EXPECT_EQ(p.v_max, 1.0);
  EXPECT_EQ(p.omega_max, 8.0);
  EXPECT_EQ(p.deadband_left, 0.0);
  EXPECT_EQ(p.deadband_right, 0.0);
  EXPECT_NO_THROW(p.validate());
  ASSERT_EQ(kinematicsFields().size(), 10u);
  EXPECT_STREQ(kinematicsFields().front().key, "gain");
  EXPECT_STREQ(kinematicsFields().back().key, "deadband_right");
}

TEST(Kinematics, StraightAndPureRotation) {
  const KinematicsParams p;
  const WheelDuties straight = carCmdToDuties(p, 0.3, 0.0);
  EXPECT_NEAR(straight.left, 0.3 / (0.0318 * 27), kTol);
  EXPECT_NEAR(straight.right, 0.3 / (0.0318 * 27), kTol);
  EXPECT_NEAR(straight.left, 0.349406, 1e-6);

  const WheelDuties spin = carCmdToDuties(p, 0.0, 2.0);
  EXPECT_NEAR(spin.right, 2.0 * 0.05 / (0.0318 * 27), kTol);
  EXPECT_NEAR(spin.left, -spin.right, kTol);
  EXPECT_GT(spin.right, 0.0) << "counter-clockwise turns speed the right wheel up";

  const WheelDuties back = carCmdToDuties(p, -0.2, 0.0);
  EXPECT_NEAR(back.left, -0.2 / (0.0318 * 27), kTol);
  const WheelDuties stop = carCmdToDuties(p, 0.0, 0.0);
  EXPECT_EQ(stop.left, 0.0);
  EXPECT_EQ(stop.right, 0.0);

  const CarCommand arc{0.2, 1.5};
  const WheelDuties d = carCmdToDuties(p, arc);
  EXPECT_NEAR(d.right, closedFormRight(1, 0, 0.2, 1.5), kTol);
  EXPECT_NEAR(d.left, closedFormLeft(1, 0, 0.2, 1.5), kTol);
}

TEST(Kinematics, TrimOfBothSignsAndGain) {
  for (double trim : {0.1, -0.1, 0.08, -0.09}) {
    for (double gain : {1.0, 0.6, 1.2}) {
      KinematicsParams p;
      p.gain = gain;
      p.trim = trim;
      for (const auto& vw : {std::make_pair(0.25, 0.0), std::make_pair(0.1, -2.0)}) {
        const WheelDuties d = carCmdToDuties(p, vw.first, vw.second);
        EXPECT_NEAR(d.right, closedFormRight(gain, trim, vw.first, vw.second), kTol);
        EXPECT_NEAR(d.left, closedFormLeft(gain, trim, vw.first, vw.second), kTol);
      }
      const WheelDuties straight = carCmdToDuties(p, 0.25, 0.0);
      if (trim > 0) {
        EXPECT_GT(straight.right, straight.left) << "trim > 0 speeds the right wheel up";
      }
      if (trim < 0) {
        EXPECT_LT(straight.right, straight.left);
      }
      EXPECT_NEAR(straight.right / straight.left, speedRatioFromTrim(trim, gain), 1e-12);
    }
  }
}

TEST(Kinematics, SpeedRatioAndTrimRoundTrip) {
  EXPECT_NEAR(speedRatioFromTrim(0.05, 1.0), 1.05 / 0.95, kTol);
  EXPECT_NEAR(speedRatioFromTrim(-0.05, 1.0), 0.95 / 1.05, kTol);
  EXPECT_EQ(speedRatioFromTrim(0.0, 0.7), 1.0);
  EXPECT_NEAR(trimFromSpeedRatio(1.0, 1.0), 0.0, kTol);
  EXPECT_NEAR(trimFromSpeedRatio(1.1, 1.0), 0.1 / 2.1, kTol);
  for (double gain : {0.6, 1.0, 1.2}) {
    for (double trim : {-0.09, -0.01, 0.0, 0.03, 0.08, 0.5}) {
      EXPECT_NEAR(trimFromSpeedRatio(speedRatioFromTrim(trim, gain), gain), trim, 1e-12);
    }
    for (double ratio : {0.8, 0.97, 1.0, 1.04, 1.3}) {
      EXPECT_NEAR(speedRatioFromTrim(trimFromSpeedRatio(ratio, gain), gain), ratio, 1e-12);
    }
  }
  EXPECT_THROW(speedRatioFromTrim(1.0, 1.0), ConfigError);
  EXPECT_THROW(speedRatioFromTrim(0.1, 0.0), ConfigError);
  EXPECT_THROW(trimFromSpeedRatio(0.0, 1.0), InputError);
  EXPECT_THROW(trimFromSpeedRatio(NAN, 1.0), InputError);
  EXPECT_THROW(trimFromSpeedRatio(1.0, -1.0), ConfigError);
}

TEST(Kinematics, DutiesAreClippedToTheLimit) {
  KinematicsParams p;
  // v = 1 m/s is 1.1647 duty: over the default limit 1.
  const WheelDuties full = carCmdToDuties(p, 1.0, 0.0);
  EXPECT_EQ(full.left, 1.0);
  EXPECT_EQ(full.right, 1.0);
  p.limit = 0.5;
  const WheelDuties half = carCmdToDuties(p, 0.6, 0.0);
  EXPECT_EQ(half.left, 0.5);
  EXPECT_EQ(half.right, 0.5);
  const WheelDuties reverse = carCmdToDuties(p, -0.6, 0.0);
  EXPECT_EQ(reverse.left, -0.5);
  // Only the wheel over the limit is clipped.
  const WheelDuties turn = carCmdToDuties(p, 0.3, 4.0);
  EXPECT_EQ(turn.right, 0.5);
  EXPECT_NEAR(turn.left, closedFormLeft(1, 0, 0.3, 4.0), kTol);
  // The clip also applies after the deadband compensation.
  p.deadband_left = p.deadband_right = 0.3;
  const WheelDuties db = carCmdToDuties(p, 0.3, 0.0);
  EXPECT_EQ(db.left, 0.5);
}

TEST(Kinematics, SpeedsAreClampedToVmaxAndOmegaMax) {
  KinematicsParams p;
  p.v_max = 0.2;
  p.omega_max = 1.0;
  p.trim = 0.05;
  auto same = [](const WheelDuties& a, const WheelDuties& b) {
    EXPECT_NEAR(a.left, b.left, kTol);
    EXPECT_NEAR(a.right, b.right, kTol);
  };
  same(carCmdToDuties(p, 0.5, 0.0), carCmdToDuties(p, 0.2, 0.0));
  same(carCmdToDuties(p, -0.5, 0.0), carCmdToDuties(p, -0.2, 0.0));
  same(carCmdToDuties(p, 0.0, 5.0), carCmdToDuties(p, 0.0, 1.0));
  same(carCmdToDuties(p, 0.1, -5.0), carCmdToDuties(p, 0.1, -1.0));
  const WheelDuties both = carCmdToDuties(p, 3.0, 9.0);
  EXPECT_NEAR(both.right, closedFormRight(1, 0.05, 0.2, 1.0), kTol);
  EXPECT_NEAR(both.left, closedFormLeft(1, 0.05, 0.2, 1.0), kTol);
}

TEST(Kinematics, DeadbandCompensationAndItsInverse) {
  EXPECT_NEAR(compensateDeadband(0.5, 0.2), 0.6, kTol);
  EXPECT_NEAR(compensateDeadband(-0.5, 0.2), -0.6, kTol);
  EXPECT_NEAR(compensateDeadband(1.0, 0.2), 1.0, kTol);
  EXPECT_NEAR(compensateDeadband(1e-9, 0.2), 0.2, 1e-9) << "any motion starts at the deadband";
  EXPECT_EQ(compensateDeadband(0.0, 0.2), 0.0) << "a stop stays a stop";
  EXPECT_EQ(compensateDeadband(0.37, 0.0), 0.37) << "offset 0 is Duckietown's semantics";
  EXPECT_NEAR(removeDeadband(0.6, 0.2), 0.5, kTol);
  EXPECT_NEAR(removeDeadband(-0.6, 0.2), -0.5, kTol);
  for (double d : {0.0, 0.1, -0.15, 0.2, -0.2}) {
    EXPECT_EQ(removeDeadband(d, 0.2), 0.0) << d << " is inside the deadband";
  }
  for (double o : {0.0, 0.1, 0.25, 0.6}) {
    for (double u = -1.0; u <= 1.0; u += 0.05) {
      EXPECT_NEAR(removeDeadband(compensateDeadband(u, o), o), u, 1e-12) << u << " " << o;
    }
  }
}

TEST(Kinematics, SpeedsToDutiesAndBackAreInverse) {
  KinematicsParams p;
  p.gain = 0.9;
  p.trim = -0.06;
  p.deadband_left = 0.12;
  p.deadband_right = 0.18;
  for (double l : {-20.0, -5.0, -0.5, 0.0, 0.3, 7.0, 18.0}) {
    for (double r : {-15.0, 0.0, 1.0, 12.0, 20.0}) {
      const WheelDuties d = speedsToDuties(p, {l, r});
      ASSERT_LT(std::abs(d.left), p.limit);
      ASSERT_LT(std::abs(d.right), p.limit);
      const WheelSpeeds s = dutiesToSpeeds(p, d);
      EXPECT_NEAR(s.left, l, 1e-9);
      EXPECT_NEAR(s.right, r, 1e-9);
    }
  }
  // Closed form: u_r = (gain + trim)·ω_r/k, then d = o + (1 − o)·u.
  const WheelDuties d = speedsToDuties(p, {10.0, 10.0});
  EXPECT_NEAR(d.right, 0.18 + 0.82 * 0.84 * 10 / 27, kTol);
  EXPECT_NEAR(d.left, 0.12 + 0.88 * 0.96 * 10 / 27, kTol);
  // A duty inside the deadband does not turn the wheel.
  const WheelSpeeds still = dutiesToSpeeds(p, {0.1, -0.15});
  EXPECT_EQ(still.left, 0.0);
  EXPECT_EQ(still.right, 0.0);
}

TEST(Kinematics, WithTheDeadbandSetOneTrimIsRightAtEverySpeed) {
  // A motor whose speed is zero below the deadband o and linear above it, the right one 8 %
  // faster: trim = trimFromSpeedRatio(1/1.08) straightens it at every commanded speed.
  const double o = 0.15, k_true = 25.0;
  auto motor = [&](double duty, double factor) {
    return factor * k_true * removeDeadband(duty, o);
  };
  KinematicsParams p;
  p.deadband_left = p.deadband_right = o;
  p.trim = trimFromSpeedRatio(1.0 / 1.08, p.gain);
  for (double v : {0.05, 0.1, 0.2, 0.4}) {
    const WheelDuties d = carCmdToDuties(p, v, 0.0);
    EXPECT_NEAR(motor(d.right, 1.08) / motor(d.left, 1.0), 1.0, 1e-12) << v;
  }
  // Without the compensation (Duckietown's semantics) the same trim is right at no speed.
  p.deadband_left = p.deadband_right = 0.0;
  for (double v : {0.2, 0.3}) {  // both wheels above the deadband
    const WheelDuties d = carCmdToDuties(p, v, 0.0);
    ASSERT_GT(d.right, o);
    EXPECT_GT(std::abs(motor(d.right, 1.08) / motor(d.left, 1.0) - 1.0), 1e-3) << v;
  }
}

TEST(Kinematics, ValidateNamesTheBadKey) {
  struct Case {
    std::string key;
    std::function<void(KinematicsParams&)> spoil;
  };
  const std::vector<Case> cases{
      {"gain", [](KinematicsParams& p) { p.gain = 0.0; }},
      {"gain", [](KinematicsParams& p) { p.gain = NAN; }},
      {"trim", [](KinematicsParams& p) { p.trim = 1.0; }},
      {"trim", [](KinematicsParams& p) { p.trim = -1.5; }},
      {"trim", [](KinematicsParams& p) { p.trim = INFINITY; }},
      {"baseline", [](KinematicsParams& p) { p.baseline = -0.1; }},
      {"radius", [](KinematicsParams& p) { p.radius = 0.0; }},
      {"k", [](KinematicsParams& p) { p.k = 0.0; }},
      {"limit", [](KinematicsParams& p) { p.limit = 0.0; }},
      {"v_max", [](KinematicsParams& p) { p.v_max = -1.0; }},
      {"omega_max", [](KinematicsParams& p) { p.omega_max = 0.0; }},
      {"deadband_left", [](KinematicsParams& p) { p.deadband_left = 1.0; }},
      {"deadband_right", [](KinematicsParams& p) { p.deadband_right = -0.01; }},
  };
  for (const Case& c : cases) {
    KinematicsParams p;
    c.spoil(p);
    const std::string what = messageOf([&] { p.validate(); });
    EXPECT_EQ(what.rfind(c.key + ":", 0), 0u) << c.key << ": " << what;
  }
}

TEST_F(KinematicsFile, PathOfTheVehicle) {
  EXPECT_EQ(kinematicsPath("/data/config/calibrations", "autobot"),
            "/data/config/calibrations/kinematics/autobot.yaml");
  EXPECT_THROW(kinematicsPath("/x", ""), ConfigError);
  EXPECT_THROW(kinematicsPath("/x", "a/b"), ConfigError);
  EXPECT_THROW(kinematicsPath("", "autobot"), ConfigError);
}

TEST_F(KinematicsFile, RoundTripWithCalibrationTime) {
  KinematicsParams p;
  p.gain = 0.87;
  p.trim = -0.0734512345678;
  p.baseline = 0.102;
  p.radius = 0.0321;
  p.k = 26.5;
  p.limit = 0.9;
  p.v_max = 0.6;
  p.omega_max = 6.0;
  p.deadband_left = 0.11;
  p.deadband_right = 0.135;
  const std::string path = kinematicsPath(dir_.string(), "autobot");
  const std::string time = writeKinematicsFile(path, p);
  EXPECT_TRUE(std::regex_match(time, std::regex(R"(\d{4}-\d\d-\d\d-\d\d-\d\d-\d\d)"))) << time;
  const KinematicsParams back = readKinematicsFile(path);
  for (const KinematicsField& f : kinematicsFields()) {
    EXPECT_EQ(back.*f.member, p.*f.member) << f.key << ": the file keeps every digit";
  }
  const std::string text = readFile(path);
  EXPECT_EQ(text.rfind("calibration_time: " + time + "\ngain: 0.87\ntrim: ", 0), 0u) << text;
  EXPECT_NE(text.find("\nk: 26.5\nlimit: 0.9\nv_max: 0.6\nomega_max: 6.0\ndeadband_left: 0.11\n"),
            std::string::npos)
      << text;
  const YAML::Node y = YAML::Load(text);
  EXPECT_EQ(y["calibration_time"].as<std::string>(), time);
  EXPECT_FALSE(fs::exists(path + ".prev"));

  // A second write keeps the first file as .prev.
  KinematicsParams q = p;
  q.trim = 0.02;
  writeKinematicsFile(path, q);
  EXPECT_EQ(readKinematicsFile(path).trim, 0.02);
  EXPECT_EQ(readKinematicsFile(path + ".prev").trim, p.trim);
}

TEST_F(KinematicsFile, DuckietownFileReadsWithDefaultsForMissingKeys) {
  // An older fleet file: no v_max, omega_max or deadband keys, integers where numbers are.
  const std::string path = write("duckiebot.yaml",
                                 "baseline: 0.1\ncalibration_time: 1999-09-25-16-58-23\n"
                                 "gain: 1\nk: 27\nlimit: 1.0\nradius: 0.0318\ntrim: -0.0427\n");
  const KinematicsParams p = readKinematicsFile(path);
  EXPECT_EQ(p.trim, -0.0427);
  EXPECT_EQ(p.gain, 1.0);
  EXPECT_EQ(p.v_max, 1.0);
  EXPECT_EQ(p.omega_max, 8.0);
  EXPECT_EQ(p.deadband_left, 0.0);
}

TEST_F(KinematicsFile, MissingFileMeansDefaultsOnlyWhenAskedFor) {
  const std::string path = kinematicsPath(dir_.string(), "nobody");
  const KinematicsParams p = readKinematicsFileOrDefaults(path);
  EXPECT_EQ(p.gain, 1.0);
  EXPECT_EQ(p.trim, 0.0);
  EXPECT_EQ(p.k, 27.0);
  EXPECT_THROW(readKinematicsFile(path), IoError);
  EXPECT_FALSE(fs::exists(path)) << "reading never creates the file";
}

TEST_F(KinematicsFile, MalformedFilesNameTheFileAndKey) {
  struct Case {
    std::string name, text, must_mention;
  };
  const std::vector<Case> cases{
      {"bad_yaml.yaml", "gain: [1.0,\ntrim: 0.1\n", "not valid YAML"},
      {"unknown.yaml", "gain: 1.0\ntrimm: 0.1\n", "trimm: unknown key"},
      {"not_number.yaml", "gain: 1.0\ntrim: abc\n", "trim: expected a number, got 'abc'"},
      {"trim_ge_gain.yaml", "gain: 0.5\ntrim: 0.5\n", "trim: |trim| must be < gain"},
      {"negative_trim.yaml", "gain: 0.8\ntrim: -0.9\n", "trim: |trim| must be < gain"},
      {"deadband.yaml", "deadband_left: 1.2\n", "deadband_left: must be within [0, 1)"},
      {"radius.yaml", "radius: 0\n", "radius: must be > 0"},
      {"list.yaml", "- 1\n- 2\n", "expected a map"},
      {"nan.yaml", "k: .nan\n", "k: must be a finite number"},
  };
  for (const Case& c : cases) {
    const std::string path = write(c.name, c.text);
    std::string what;
    try {
      readKinematicsFileOrDefaults(path);
      ADD_FAILURE() << c.name << " was accepted";
    } catch (const ConfigError& e) {
      what = e.what();
    }
    EXPECT_NE(what.find(path), std::string::npos) << c.name << ": " << what;
    EXPECT_NE(what.find(c.must_mention), std::string::npos) << c.name << ": " << what;
  }
  // The line of the bad key is named too.
  const std::string path = write("line.yaml", "gain: 1.0\nbaseline: 0.1\ntrim: 2.0\n");
  EXPECT_NE(messageOf([&] { readKinematicsFile(path); }).find(path + ":3: trim"),
            std::string::npos);
}

TEST_F(KinematicsFile, FailedValidationNeverTouchesTheFile) {
  const std::string path = kinematicsPath(dir_.string(), "autobot");
  KinematicsParams good;
  good.trim = 0.04;
  writeKinematicsFile(path, good);
  writeKinematicsFile(path, good);  // now there is a .prev too
  const std::string before = readFile(path), prev_before = readFile(path + ".prev");
  KinematicsParams bad = good;
  bad.trim = 1.0;
  const std::string what = messageOf([&] { writeKinematicsFile(path, bad); });
  EXPECT_EQ(what.rfind("trim:", 0), 0u) << what;
  bad = good;
  bad.k = NAN;
  EXPECT_THROW(writeKinematicsFile(path, bad), ConfigError);
  EXPECT_EQ(readFile(path), before);
  EXPECT_EQ(readFile(path + ".prev"), prev_before);
  // Nor does it create a missing one.
  const std::string other = kinematicsPath(dir_.string(), "other");
  EXPECT_THROW(writeKinematicsFile(other, bad), ConfigError);
  EXPECT_FALSE(fs::exists(other));
}

TEST_F(KinematicsFile, FailedWriteIsIoError) {
  // The kinematics folder is a regular file: nothing can be written below it (even as root).
  fs::create_directories(dir_);
  std::ofstream((dir_ / "kinematics").string()) << "not a folder\n";
  EXPECT_THROW(writeKinematicsFile(kinematicsPath(dir_.string(), "autobot"), KinematicsParams()),
               IoError);
}
