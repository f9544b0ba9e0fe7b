#include "support/wheels_in_sim.h"

#include <cmath>
#include <cstdio>

#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "autocal/sim/straight_drift.h"
#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

WheelsInSim runWheelsInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                           wheels::WheelRun& run, const WheelsInSimOptions& options) {
  sim::Simulation simulation(robot, world, sim::SimulationOptions());
  sim::Renderer renderer = robotRenderer(robot, world, options.seed);

  WheelsInSim out;
  out.start_pose = simulation.pose();
  double next_path = 0;
  wheels::WheelRunStage last_stage = run.stage();
  size_t last_iterations = 0;
  StageInSimOptions o = options;
  o.phase = [&] { return std::string("wheels/") + wheels::name(run.stage()); };
  o.before_step = [&](double t) {
    if (t < next_path) return;
    out.path.push_back(simulation.pose());
    next_path += 0.1;
  };
  o.after_step = [&](double t) {
    if (!options.trace ||
        (run.stage() == last_stage && run.estimator().history().size() == last_iterations))
      return;
    const Pose2D p = simulation.pose();
    std::fprintf(stderr, "t %.2f pose (%.3f, %.3f, %.2f deg): %s\n", t, p.x_m, p.y_m,
                 p.yaw_rad * 180 / M_PI, run.describe().c_str());
    last_stage = run.stage();
    last_iterations = run.estimator().history().size();
  };
  const StageInSim r = runStageInSim(run, simulation, robot, &renderer, o);
  out.failure = r.failure;
  out.frames_processed = r.frames_processed;
  out.done = run.done();
  out.sim_s = simulation.time_s();
  out.end_pose = simulation.pose();
  out.iterations = run.estimator().history();
  out.result = run.result();
  out.wall_s = r.wall_s;
  return out;
}

std::vector<StraightDrift> straightDrifts(const sim::RobotConfig& robot,
                                          const wheels::KinematicsParams& params) {
  std::vector<StraightDrift> out;
  for (double v : {0.15, 0.25, 0.4})
    out.push_back({v, sim::straightDriftM(robot, params, v), v == 0.25 ? 0.02 : 0.03});
  return out;
}

}  // namespace test
}  // namespace autocal
