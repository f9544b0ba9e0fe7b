// compare_wheels: a validation tool of the simulator (never used by a calibration): prints the
// kinematics file a wheel calibration wrote next to what the simulated robot's TRUE wheels need.
//   rosrun autocal compare_wheels --robot-config sim/config/robot.yaml --calibration FILE.yaml
//                                 [--before FILE.yaml]
// The truth: the simulator's wheel turns at gain·K·(duty − deadband)/(1 − deadband), so with the
// deadband compensated the commands drive straight when right/left = (g_l·R_l)/(g_r·R_r), i.e.
// trim = gain·(k − 1)/(k + 1); each wheel's offset is the config's deadband.
// Exit codes: doc/calibration_run.md "Exit codes"; doc/nodes/compare_wheels.md.
#include <cmath>
#include <cstdio>
#include <string>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/sim/config.h"
#include "autocal/sim/straight_drift.h"
#include "autocal/wheels/kinematics.h"

namespace {

const char* kUsage =
    "usage: compare_wheels --robot-config ROBOT.yaml --calibration KINEMATICS.yaml "
    "[--before KINEMATICS.yaml]\n";

int run(int argc, char** argv) {
  std::string robot_path, calibration_path, before_path;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) throw autocal::UsageError(k + " needs a value");
    if (k == "--robot-config") {
      robot_path = argv[++i];
    } else if (k == "--calibration") {
      calibration_path = argv[++i];
    } else if (k == "--before") {
      before_path = argv[++i];
    } else {
      throw autocal::UsageError("unknown option " + k);
    }
  }
  if (robot_path.empty() || calibration_path.empty())
    throw autocal::UsageError("--robot-config and --calibration are required");
  const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(robot_path);
  const autocal::wheels::KinematicsParams found =
      autocal::wheels::readKinematicsFile(calibration_path);
  const autocal::wheels::KinematicsParams before =
      before_path.empty() ? autocal::wheels::KinematicsParams()
                          : autocal::wheels::readKinematicsFileOrDefaults(before_path);
  const double k_true = (robot.motor_gain_left * robot.wheel_radius_left) /
                        (robot.motor_gain_right * robot.wheel_radius_right);
  const double trim_true = autocal::wheels::trimFromSpeedRatio(k_true, found.gain);
  std::printf("%-15s %12s %12s %12s %12s\n", "", "before", "calibrated", "truth", "error");
  auto row = [](const char* what, double b, double f, double t) {
    std::printf("%-15s %12.5f %12.5f %12.5f %+12.5f\n", what, b, f, t, f - t);
  };
  row("trim", before.trim, found.trim, trim_true);
  row("k (right/left)", autocal::wheels::speedRatioFromTrim(before.trim, before.gain),
      autocal::wheels::speedRatioFromTrim(found.trim, found.gain), k_true);
  row("deadband_left", before.deadband_left, found.deadband_left, robot.deadband);
  row("deadband_right", before.deadband_right, found.deadband_right, robot.deadband);
  // Duckietown's acceptance test on the true robot: 2 m straight at three speeds.
  for (const double v : {0.15, 0.25, 0.4}) {
    std::printf("drift over 2 m at %.2f m/s: before %.1f cm, calibrated %.1f cm\n", v,
                100 * autocal::sim::straightDriftM(robot, before, v),
                100 * autocal::sim::straightDriftM(robot, found, v));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "compare_wheels", [&] { return run(argc, argv); }, kUsage);
}
