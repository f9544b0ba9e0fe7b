// Any calibration Stage (autocal/stage.h) driven by the simulator's core directly, no ROS, on sim
// time: the stage's duties go to the physics, encoders and frames come back at the robot's rates,
// and a frame is rendered only when the stage (or a recording tap) wants one, as a node drops the
// others. With `transport`, the robot's links (RobotConfig::transport) delay and drop readings,
// frames and commands as sim_node does. The stage never sees the truth; the caller compares.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "autocal/stage.h"
#include "support/recording_tap.h"

namespace autocal {
namespace test {

struct StageInSimOptions {
  double control_rate_hz = 100.0;  ///< how often the stage is updated (a node's timer)
  double max_sim_s = 300.0;        ///< give up (a bug, not a calibration failure)
  uint64_t seed = 1;               ///< the renderer's noise and the links' delays
  int max_blur_samples = 8;
  /// Deliver through the robot's links (delays, losses); false: at once.
  bool transport = true;
  /// A command reaches the motors one control step after the readings it came from (the
  /// odometry node's loop), on top of the links.
  bool command_one_step_late = false;
  /// Range readings at the sensor's rate, drawn with this generator (null: none).
  std::mt19937_64* range_rng = nullptr;
  /// Gets what a recording would hold (not owned; null: none).
  RecordingTap* tap = nullptr;
  /// The stage's phase for the tap ("camera/collect"); asked after every update when tapped.
  std::function<std::string()> phase;
  /// Called at each control step before the readings (t: sim time), and after the physics advanced.
  std::function<void(double t_s)> before_step;
  std::function<void(double t_s)> after_step;
  /// Called after the stage was given a frame it wanted; `taken`: Stage::addFrame said it took it.
  std::function<void(double t_s, bool taken)> after_frame;
  /// Faults injected between the simulator and the stage: each may alter a reading taken at t.
  std::function<void(double t_s, std::int32_t& left, std::int32_t& right)> encoders;
  std::function<void(double t_s, double& range_m)> range;
  /// Called after the readings, before the update (a measured input given to the stage), and
  /// with the duties the update returned.
  std::function<void(double t_s)> before_update;
  std::function<void(double t_s, const WheelDuties& duties)> after_update;
  /// After each update: how long [s] the world runs on before the next one, the commands held
  /// and no reading taken, as while a node computes on a robot whose world does not wait.
  std::function<double(double t_s)> world_runs_on_s;
};

struct StageInSim {
  std::string failure;  ///< the stage's error (autocal::Error), if it failed
  double wall_s = 0;
  int frames_processed = 0;
  std::vector<double> frame_ms;  ///< thread CPU time of Stage::addFrame per processed frame
};

/// The renderer of `robot`'s camera in `world` as sim_node has it (supersampling, noise seeded
/// with `seed`).
sim::Renderer robotRenderer(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                            uint64_t seed);

/// The truth: how fast the robot turned over the camera's frame period before `capture_s`
/// [rad/s] (from the pose history).
double trueYawRateRadS(const sim::Simulation& simulation, const sim::RobotConfig& robot,
                       double capture_s);

/// Runs `stage` on `simulation` (its robot `robot`) until done, failed or max_sim_s; the wheels
/// are stopped at the end. `renderer` draws the frames (null: the stage gets none).
StageInSim runStageInSim(Stage& stage, sim::Simulation& simulation, const sim::RobotConfig& robot,
                         sim::Renderer* renderer, const StageInSimOptions& options);

}  // namespace test
}  // namespace autocal
