#include "support/sweep_in_sim.h"

#include <cmath>
#include <cstdio>

#include "autocal/errors.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

camera::CameraCalibrationConfig cameraConfigFor(const sim::WorldConfig& world,
                                                const sim::RobotConfig& robot) {
  camera::CameraCalibrationConfig c = camera::loadCameraCalibrationConfig(
      std::string(AUTOCAL_SOURCE_DIR) + "/config/camera_calibration.yaml");
  c.board.inner_corners = cv::Size(world.chessboards.front().cols, world.chessboards.front().rows);
  c.board.square_size_m = world.chessboards.front().square_m;
  c.detector.half_resolution_precheck = false;
  // What camera_info says (the nominal model), as the node does.
  c.calibration.initial_camera_matrix = robot.camera.nominal.cameraMatrix();
  return c;
}

camera::SweepRunOptions runOptionsFor(const sim::RobotConfig& robot) {
  camera::SweepRunOptions o;
  // What camera_info says (the nominal model), as the node does.
  o.sweep.camera_hfov_rad =
      2 * std::atan(robot.camera.nominal.width / (2 * robot.camera.nominal.fx));
  return o;
}

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
  o.after_frame = [&](double t, bool taken) {
    if (taken) out.view_yaw_rate_rad_s.push_back(trueYawRateRadS(simulation, robot, t));
    if (options.after_frame) options.after_frame(t, taken);
    if (options.trace && taken) {
      std::string xs;
      for (const auto& d : run.lastFrame().frame.decisions)
        xs += " " + std::to_string(d.params.x).substr(0, 4);
      const camera::SweepDecision& d = run.lastFrame().decision;
      std::fprintf(stderr, "t %.2f yaw %.3f boards[%s] -> %s | %s\n", t, simulation.pose().yaw_rad,
                   xs.c_str(), d.turn() ? camera::name(d.direction) : d.reason.c_str(),
                   run.controller().describe().c_str());
    }
  };
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
      out.calibrated = camera::cornersToCalibrate(run.collector().calibrationViews(),
                                                  out.image_size, run.cameraConfig());
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
