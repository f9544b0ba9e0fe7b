// make bench, wheel stage section: the wheel stage (wheels::WheelRun) on the simulator's core over
// robot configs spanning a real fleet's trims, side by side with the paper's method alone (the same
// run with compensate_deadband false: Duckietown's kinematics exactly, one trim). Judged by the
// simulator's truth: the written kinematics driven 2 m straight at 0.15, 0.25 and 0.4 m/s,
// uncalibrated (trim 0) and calibrated. Prints Markdown on stdout.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal/sim/straight_drift.h"
#include "support/wheels_in_sim.h"

using namespace autocal;

namespace {

struct Case {
  std::string name;
  sim::RobotConfig robot;
  double deadband_guess;
};

sim::RobotConfig load(const std::string& name) {
  return sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/" + name);
}

sim::RobotConfig variant(double gl, double gr, double rl, double rr, double deadband) {
  sim::RobotConfig r = load("robot.yaml");
  r.motor_gain_left = gl, r.motor_gain_right = gr;
  r.wheel_radius_left = rl, r.wheel_radius_right = rr;
  r.deadband = deadband;
  return r;
}

/// The default robot with motors `left` and `right` times as fast backward as forward.
sim::RobotConfig backwardGains(double left, double right) {
  sim::RobotConfig r = load("robot.yaml");
  r.backward_gain_ratio_left = left, r.backward_gain_ratio_right = right;
  return r;
}

double trueTrim(const sim::RobotConfig& r) {
  const double k =
      (r.motor_gain_left * r.wheel_radius_left) / (r.motor_gain_right * r.wheel_radius_right);
  return (k - 1) / (k + 1);
}

std::string cm(double m) {
  char b[32];
  if (!std::isfinite(m)) return "turns away";
  std::snprintf(b, sizeof b, "%.1f", 100 * m);
  return b;
}

}  // namespace

int main() {
  const sim::WorldConfig world =
      sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world.yaml");
  const std::vector<Case> cases = {
      {"default (robot.yaml)", load("robot.yaml"), 0.087},
      {"right motor 19 % stronger, deadband 0.05", variant(1.0, 1.19, 0.0318, 0.0318, 0.05), 0.055},
      {"left motor 16 % stronger, deadband 0.12", variant(1.0, 0.86, 0.0318, 0.0318, 0.12), 0.126},
      {"right wheel 5 % larger, left motor 5 % weaker", variant(0.95, 1.0, 0.0318, 0.0335, 0.08),
       0.085},
      {"left wheel 2 % larger, right motor 8 % stronger, no deadband guess",
       variant(1.0, 1.08, 0.0325, 0.0318, 0.1), 0.0},
      {"default, motors 2 % slower (left) and 1 % faster (right) backward",
       backwardGains(0.98, 1.01), 0.087},
  };
  const double speeds[3] = {0.15, 0.25, 0.4};
  std::printf("### The wheel stage: autocal vs the paper's method\n\n");
  std::printf(
      "The wheel stage on the simulator's core (no ROS; one core; camera frames rendered), in the\n"
      "default world, from trim 0, for robot configs spanning a real fleet's trims (-0.09..+0.08). "
      "Each\n"
      "calibration is judged by the simulator's truth: the written kinematics driven 2 m straight "
      "on the\n"
      "true robot (Duckietown's acceptance test; it accepts 10 cm). **autocal**: the stage as "
      "shipped\n"
      "(deadband fitted and compensated); **paper**: the same run with `compensate_deadband` "
      "false, i.e.\n"
      "paper 000 §3.4 with Duckietown's kinematics exactly (one multiplicative trim, right at the\n"
      "calibration speed 0.25 m/s only).\n\n");
  std::printf(
      "| robot | method | drives | sim s | wall s | trim found | true trim | drift 0.15 / 0.25 / "
      "0.4 m/s [cm] | uncalibrated (trim 0) [cm] |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    for (bool compensate : {true, false}) {
      wheels::WheelRunOptions o;
      o.kinematics.deadband_left = o.kinematics.deadband_right = c.deadband_guess;
      o.compensate_deadband = compensate;
      wheels::WheelRun run(o, c.robot.camera.truth);
      test::WheelsInSimOptions so;
      const test::WheelsInSim r = test::runWheelsInSim(c.robot, world, run, so);
      if (!r.done) {
        std::printf("| %s | %s | failed: %s | | | | | | |\n", c.name.c_str(),
                    compensate ? "autocal" : "paper", r.failure.c_str());
        continue;
      }
      std::string after, before;
      wheels::KinematicsParams zero = r.result;
      zero.trim = 0;
      zero.deadband_left = zero.deadband_right = 0;
      for (double v : speeds) {
        after += (after.empty() ? "" : " / ") + cm(sim::straightDriftM(c.robot, r.result, v));
        before += (before.empty() ? "" : " / ") + cm(sim::straightDriftM(c.robot, zero, v));
      }
      std::printf("| %s | %s | %zu | %.0f | %.1f | %+.4f | %+.4f | %s | %s |\n", c.name.c_str(),
                  compensate ? "autocal" : "paper", r.iterations.size(), r.sim_s, r.wall_s,
                  r.result.trim, trueTrim(c.robot), after.c_str(), before.c_str());
      std::fflush(stdout);
    }
  }
  std::printf(
      "\n\"true trim\": what the simulated wheels need with the deadband compensated, (k - 1)/(k + "
      "1) with\n"
      "k = (g_l R_l)/(g_r R_r). \"turns away\": the robot never gets 2 m along its start line.\n\n"
      "Reproduce: `make build && taskset -c 0 build/bench/wheel_bench` (or "
      "`scripts/bench/wheels.sh`).\n");
  return 0;
}
