// The in-lane refinement (wheels::LaneRefiner) driven on the simulator's core, no ROS, on sim
// time: the harness stands in for the kinematics node (the refiner's car commands through the
// current kinematics, whose trim it sets on an application) and for the lane follower (outside a
// pass it drives straight ahead with the same kinematics). Each pass starts from a given pose (the
// simulator is rebuilt there: a teleport; the clock and the encoder counts carry on). The refiner
// never sees the truth; the harness records it.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"
#include "autocal/wheels/lane_refiner.h"

namespace autocal {
namespace test {

struct LaneInSimOptions {
  double control_rate_hz = 100.0;
  double max_pass_sim_s = 30.0;  ///< per runPass
  uint64_t seed = 1;
  int max_blur_samples = 2;
  /// The lane follower's stand-in, outside a pass: v [m/s], ω = −gain_y·y − gain_yaw·yaw [1/(m·s),
  /// 1/s] on the truth (a real one sees the lane lines; with a trim off it keeps an offset).
  double follower_speed_mps = 0.2;
  double follower_gain_y = 12.0;
  double follower_gain_yaw = 5.0;
  bool trace = false;  ///< one stderr line per phase change and part
};

struct LanePassInSim {
  bool ended = false;  ///< a pass started and ended within max_pass_sim_s
  wheels::LanePass pass;
  bool applied = false;
  double applied_trim = 0;
  double max_abs_lateral_m = 0;      ///< the truth's |y| while the refiner commanded
  double max_abs_lateral_any_m = 0;  ///< the truth's |y| over the whole run
  double sim_s = 0, wall_s = 0;
  int frames = 0;
  Pose2D end_pose;
};

class LaneInSim {
 public:
  LaneInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
            const wheels::KinematicsParams& kinematics, const LaneInSimOptions& options);
  /// Rebuilds the simulator at `start` and runs until one pass has ended (or the time is up).
  LanePassInSim runPass(wheels::LaneRefiner& refiner, const Pose2D& start);
  /// The kinematics node's parameters (the trim changes with each application).
  const wheels::KinematicsParams& kinematics() const { return kinematics_; }

 private:
  sim::RobotConfig robot_;
  sim::WorldConfig world_;
  wheels::KinematicsParams kinematics_;
  LaneInSimOptions options_;
  std::mt19937_64 rng_;
  double clock_s_ = 0;
  int left_offset_ = 0, right_offset_ = 0;
};

}  // namespace test
}  // namespace autocal
