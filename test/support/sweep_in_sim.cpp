#include "support/sweep_in_sim.h"

#include <cstdio>

#include "autocal/errors.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

SweepInSim runSweepInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                         camera::SweepRun& run, const SweepInSimOptions& options) {
  sim::Simulation simulation(robot, world, sim::SimulationOptions());
  sim::Renderer renderer = robotRenderer(robot, world, options.seed);

  SweepInSim out;
  StageInSimOptions o = options;
  o.phase = [&] { return std::string("camera/") + camera::name(run.stage()); };
  o.after_step = [&](double t) {
    if (out.progress.empty() || out.progress.back().second != run.progress())
      out.progress.emplace_back(t, run.progress());
  };
  if (options.trace) {
    o.after_frame = [&](double t) {
      std::string xs;
      for (const auto& d : run.lastFrame().frame.decisions)
        xs += " " + std::to_string(d.params.x).substr(0, 4);
      const camera::SweepDecision& d = run.lastFrame().decision;
      std::fprintf(stderr, "t %.2f yaw %.3f boards[%s] -> %s | %s\n", t, simulation.pose().yaw_rad,
                   xs.c_str(), d.turn() ? camera::name(d.direction) : d.reason.c_str(),
                   run.controller().describe().c_str());
    };
  }
  const StageInSim r = runStageInSim(run, simulation, robot, &renderer, o);
  out.frames_rendered = r.frames_processed;
  out.frame_ms = r.frame_ms;
  if (!r.failure.empty())
    out.failure = r.failure + " [" + run.collector().coverage().summary() + "]";
  out.progress.emplace_back(simulation.time_s(), run.progress());
  out.swept = run.swept();
  out.sim_s = run.elapsedS();
  out.views = static_cast<int>(run.collector().views().size());
  out.sharp_views = static_cast<int>(run.sharpViews().size());
  out.steps = run.controller().steps();
  out.board = run.collector().board();
  out.calibration_options = run.cameraConfig().calibration;
  out.image_size = run.collector().imageSize();
  for (const camera::CalibrationView& v : run.sharpViews()) out.sharp.push_back(v.corners);
  if (run.stage() != camera::SweepRunStage::kWaitForData) out.min_duty = run.minDuty();
  if (out.swept) {
    try {
      out.result = run.calibrate();
    } catch (const CalibrationError& e) {
      out.calibration_failure = e.what();
    }
  }
  out.wall_s = r.wall_s;
  return out;
}

}  // namespace test
}  // namespace autocal
