#include "support/sweep_in_sim.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <random>

#include "autocal/errors.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"

namespace autocal {
namespace test {

SweepInSim runSweepInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                         camera::SweepRun& run, const SweepInSimOptions& options) {
  const auto wall0 = std::chrono::steady_clock::now();
  sim::Simulation simulation(robot, world, sim::SimulationOptions());
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  render.noise_seed = options.seed;
  sim::Renderer renderer(robot.camera, world, render);
  std::mt19937_64 rng(options.seed);

  SweepInSim out;
  const double control_dt = 1.0 / options.control_rate_hz;
  const double frame_dt = 1.0 / robot.camera.rate_hz;
  const double encoder_dt = 1.0 / robot.encoder_rate_hz;
  double next_frame = 0, next_encoder = 0;
  RecordingTap* tap = options.tap;
  std::string last_phase;
  try {
    while (simulation.time_s() < options.max_sim_s && !run.swept()) {
      const double t = simulation.time_s();
      if (t >= next_encoder) {
        const int left = simulation.encoderTicks(sim::Side::kLeft);
        const int right = simulation.encoderTicks(sim::Side::kRight);
        run.addEncoders(t, left, right, robot.encoder_resolution, t);
        if (tap) tap->encoders(t, left, right, robot.encoder_resolution);
        next_encoder += encoder_dt;
      }
      if (t >= next_frame) {
        run.noteFrameArrived(t);
        const bool tap_wants = tap && tap->wantsFrame(t);
        cv::Mat tap_image;
        if (tap_wants && !run.wantsFrame(t)) {
          tap_image = renderer.render(simulation.exposurePoses(t, options.max_blur_samples), rng);
          tap->frame(t, tap_image);
        }
        if (run.wantsFrame(t)) {
          const cv::Mat image =
              renderer.render(simulation.exposurePoses(t, options.max_blur_samples), rng);
          if (tap_wants) tap->frame(t, image);
          ++out.frames_rendered;
          timespec c0, c1;
          clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
          run.addFrame(t, image, "sim@" + std::to_string(t));
          clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
          out.frame_ms.push_back((c1.tv_sec - c0.tv_sec) * 1e3 + (c1.tv_nsec - c0.tv_nsec) * 1e-6);
          if (options.trace) {
            std::string xs;
            for (const auto& d : run.lastFrame().frame.decisions)
              xs += " " + std::to_string(d.params.x).substr(0, 4);
            const camera::SweepDecision& d = run.lastFrame().decision;
            std::fprintf(stderr, "t %.2f yaw %.3f boards[%s] -> %s | %s\n", t,
                         simulation.pose().yaw_rad, xs.c_str(),
                         d.turn() ? camera::name(d.direction) : d.reason.c_str(),
                         run.controller().describe().c_str());
          }
        }
        next_frame += frame_dt;
      }
      const WheelDuties d = run.update(t);
      if (out.progress.empty() || out.progress.back().second != run.progress())
        out.progress.emplace_back(t, run.progress());
      if (tap) {
        const std::string phase = std::string("camera/") + camera::name(run.stage());
        if (phase != last_phase) tap->phase(t, phase);
        last_phase = phase;
        tap->command(t, d);
      }
      simulation.setDuty(d.left, d.right);
      simulation.advance(control_dt);
    }
  } catch (const CalibrationError& e) {
    out.failure = std::string(e.what()) + " [" + run.collector().coverage().summary() + "]";
  }
  simulation.setDuty(0, 0);
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
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return out;
}

}  // namespace test
}  // namespace autocal
