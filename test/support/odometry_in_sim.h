// The odometry calibrations (odometry::UahRun, odometry::UmbmarkRun) driven by the simulator's
// core directly, no ROS, on sim time, with the node's loop (50 Hz, a command applied one cycle
// after the readings it came from). The runs never see the truth: the only measured inputs — a
// straight run's length (UAH), a square's return error (UMBmark) — come from the simulator's pose
// here, as a ground-truth helper gives them through ROS. The caller compares with the truth.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "autocal/odometry/uah_run.h"
#include "autocal/odometry/umbmark_run.h"
#include "autocal/sim/config.h"
#include "autocal/sim/simulation.h"

namespace autocal {
namespace test {

/// The floor the robot's footprint swept [m] (axis-aligned box of the chassis corners).
struct FloorBox {
  double min_x_m = 1e9, min_y_m = 1e9, max_x_m = -1e9, max_y_m = -1e9;
  void add(const sim::RobotConfig& robot, const Pose2D& pose);
  double widthM() const { return max_x_m - min_x_m; }
  double heightM() const { return max_y_m - min_y_m; }
};

struct OdometryInSim {
  bool done = false;
  std::string failure;
  double sim_s = 0;  ///< simulated time the run took
  double wall_s = 0;
  FloorBox floor;
};

struct UahInSim : OdometryInSim {
  odometry::UahResult result;
};

struct UmbmarkInSim : OdometryInSim {
  odometry::UmbmarkResult result;
  std::vector<odometry::ReturnError> cw, ccw;  ///< the errors given (also when the run failed)
};

/// Runs UAH on `simulation` from where its robot stands until done, failed or max_sim_s more.
UahInSim runUahInSim(sim::Simulation& simulation, const odometry::UahRunOptions& options,
                     std::mt19937_64& rng, double max_sim_s = 900);

/// Runs UMBmark on `simulation` from where its robot stands. Each run's return error is the
/// truth: the axle centre's end relative to its start, in the start pose's frame, minus the
/// run's computed end.
UmbmarkInSim runUmbmarkInSim(sim::Simulation& simulation,
                             const odometry::UmbmarkRunOptions& options, double max_sim_s = 1800);

/// The robots of the odometry tests (issue 11): Duckiebot-like ones and a larger robot.
struct OdometryTestRobot {
  std::string label;
  sim::RobotConfig robot;
  double nominal_radius_m, nominal_wheelbase_m;  ///< what the calibration is told
};
std::vector<OdometryTestRobot> odometryTestRobots();

/// The truth a calibration is judged by: Ed = r_R/r_L, and the wheelbase in wheel pulses relative
/// to the nominal one, (b/c̄)/(b_n/c̄_n) — what UMBmark's Eb measures (its correction keeps the
/// mean distance per pulse nominal, so a wrong nominal radius shows up in Eb; DESIGN.md).
double trueEd(const sim::RobotConfig& robot);
double trueEb(const sim::RobotConfig& robot, double nominal_radius_m, double nominal_wheelbase_m);

}  // namespace test
}  // namespace autocal
