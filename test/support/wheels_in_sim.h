// The wheel stage (wheels::WheelRun) driven by the simulator's core directly, no ROS, on sim
// time; and Duckietown's acceptance test (drive 2 m straight, measure the drift) on the
// simulator's truth. The run never sees the truth; the caller compares.
#pragma once

#include <string>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"
#include "autocal/wheels/wheel_run.h"
#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

/// The loop's options (through the robot's links), and a trace.
struct WheelsInSimOptions : StageInSimOptions {
  bool trace = false;  ///< one stderr line per stage change and iteration
};

struct WheelsInSim {
  bool done = false;
  std::string failure;
  double sim_s = 0, wall_s = 0;
  int frames_processed = 0;
  wheels::KinematicsParams result;
  std::vector<wheels::TrimIteration> iterations;
  Pose2D start_pose, end_pose;  ///< the truth
  std::vector<Pose2D> path;     ///< the truth, every 0.1 s
};

WheelsInSim runWheelsInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                           wheels::WheelRun& run, const WheelsInSimOptions& options);

/// The wheel stage's targets on the simulator's truth: sim::straightDriftM at 0.15, 0.25 and 0.4
/// m/s, at most 2 cm at 0.25 (the calibration's speed) and 3 cm at the others. The trim alone is no
/// measure when the deadbands are compensated: a trim and offsets that differ together by a few
/// thousandths command the same duties.
struct StraightDrift {
  double speed_mps = 0, drift_m = 0, bound_m = 0;
};
std::vector<StraightDrift> straightDrifts(const sim::RobotConfig& robot,
                                          const wheels::KinematicsParams& params);

}  // namespace test
}  // namespace autocal
