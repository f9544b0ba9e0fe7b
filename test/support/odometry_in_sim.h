// The odometry calibrations (odometry::UahRun, odometry::UmbmarkRun) driven by the simulator's
// core directly, no ROS, on sim time, with the node's loop (50 Hz, a command applied one cycle
// after the readings it came from). The runs never see the truth: the only measured inputs — a
// straight run's length (UAH), a square's return error (UMBmark) — come from the simulator's pose
// here, as a ground-truth helper gives them through ROS. The caller compares with the truth.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "autocal/odometry/uah_replay.h"
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
  /// The robot's true heading at the start of each straight run minus its heading at the start of
  /// the run [rad, within ±π] (the turns end on whole rounds: about 0).
  std::vector<double> straight_start_yaw_rad;
  int face_turns = 0;  ///< turns back to the starting heading before the straight runs
  odometry::UahResult result;
  std::vector<odometry::UahTurn> turns;              ///< also when the run failed
  std::vector<odometry::StraightRun> straight_runs;  ///< also when the run failed
};

/// Faults injected between the simulator and the run (what bad drivers or a bad setup produce):
/// each hook, when set, may alter a reading before the run sees it. Times are simulated [s].
struct UahSensorHooks {
  /// The encoder counts read at t_s.
  std::function<void(double t_s, std::int32_t& left, std::int32_t& right)> encoders;
  /// A range reading [m] taken at t_s (the run's rng, for random dropouts).
  std::function<void(double t_s, double& range_m, std::mt19937_64& rng)> range;
  /// The straight run's true length [m] as measured; returns the length given to the run.
  std::function<double(double length_m)> straight_length;
  /// When set, what a bag of the node's run would hold (the readings as the run saw them, its
  /// commands, a status on every change of experiment, round, straight run or waiting, as the
  /// node publishes it, and the lengths given): the input of odometry::replayUah.
  odometry::UahRecording* recording = nullptr;
  /// The robot's links (RobotConfig::transport) delay the readings and the commands as sim_node
  /// does (false: the readings at once).
  bool transport = false;
};

struct UmbmarkInSim : OdometryInSim {
  odometry::UmbmarkResult result;
  std::vector<odometry::ReturnError> cw, ccw;  ///< the errors given (also when the run failed)
};

/// Runs UAH on `simulation` from where its robot stands until done, failed or max_sim_s more.
/// AUTOCAL_TRACE=1 prints each change of experiment, AUTOCAL_TRACE_STRAIGHT=1 the straight runs.
UahInSim runUahInSim(sim::Simulation& simulation, const odometry::UahRunOptions& options,
                     std::mt19937_64& rng, double max_sim_s = 900,
                     const UahSensorHooks& hooks = UahSensorHooks());

/// Runs UMBmark on `simulation` from where its robot stands. Each run's return error is the
/// truth: the axle centre's end relative to its start, in the start pose's frame, minus the
/// run's computed end.
UmbmarkInSim runUmbmarkInSim(sim::Simulation& simulation,
                             const odometry::UmbmarkRunOptions& options, double max_sim_s = 1800);

/// robot.yaml as a robot whose UAH turns ended 18 deg off its heading in robot mode (static
/// friction, gearbox play, gains that differ between the directions), its readings and commands
/// 50 ms late (in robot mode the node's loop and ROS add to the links' 30 ms). Run it with
/// UahSensorHooks::transport.
sim::RobotConfig stickyLateRobot();

/// The robots of the odometry tests: Duckiebot-like ones and a larger robot.
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
