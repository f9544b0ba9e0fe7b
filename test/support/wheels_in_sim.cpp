#include "support/wheels_in_sim.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "autocal/errors.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "autocal/sim/straight_drift.h"
#include "autocal/sim/transport.h"

namespace autocal {
namespace test {

WheelsInSim runWheelsInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                           wheels::WheelRun& run, const WheelsInSimOptions& options) {
  const auto wall0 = std::chrono::steady_clock::now();
  sim::Simulation simulation(robot, world, sim::SimulationOptions());
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  render.noise_seed = options.seed;
  sim::Renderer renderer(robot.camera, world, render);
  std::mt19937_64 rng(options.seed);

  WheelsInSim out;
  out.start_pose = simulation.pose();
  const double control_dt = 1.0 / options.control_rate_hz;
  const double frame_dt = 1.0 / robot.camera.rate_hz;
  const double encoder_dt = 1.0 / robot.encoder_rate_hz;
  double next_frame = 0, next_encoder = 0, next_path = 0;
  wheels::WheelRunStage last_stage = run.stage();
  size_t last_iterations = 0;
  RecordingTap* tap = options.tap;
  std::string last_phase;
  // The robot's links (RobotConfig::transport), as sim_node has them: a reading or frame is
  // delivered (and the frame rendered, from the pose history) at its release time, with its
  // capture stamp; a command reaches the motors late.
  using Delivery = std::function<void(double now_s)>;
  sim::DelayQueue<Delivery> encoder_link(robot.transport.encoders, options.seed * 8 + 4);
  sim::DelayQueue<Delivery> camera_link(robot.transport.camera, options.seed * 8 + 3);
  sim::DelayQueue<WheelDuties> command_link(robot.transport.wheels_cmd, options.seed * 8 + 7);
  try {
    while (simulation.time_s() < options.max_sim_s && !run.done()) {
      const double t = simulation.time_s();
      if (t >= next_path) {
        out.path.push_back(simulation.pose());
        next_path += 0.1;
      }
      if (t >= next_encoder) {
        const int left = simulation.encoderTicks(sim::Side::kLeft);
        const int right = simulation.encoderTicks(sim::Side::kRight);
        encoder_link.push(t, [&, t, left, right](double now) {
          run.addEncoders(t, left, right, robot.encoder_resolution, now);
          if (tap) tap->encoders(t, left, right, robot.encoder_resolution);
        });
        next_encoder += encoder_dt;
      }
      if (t >= next_frame) {
        camera_link.push(t, [&, t](double now) {
          run.noteFrameArrived(now);
          const bool run_wants = run.wantsFrame(t), tap_wants = tap && tap->wantsFrame(t);
          if (!run_wants && !tap_wants) return;
          const cv::Mat image =
              renderer.render(simulation.exposurePoses(t, options.max_blur_samples), rng);
          if (run_wants) {
            run.addFrame(t, image);
            ++out.frames_processed;
          }
          if (tap_wants) tap->frame(t, image);
        });
        next_frame += frame_dt;
      }
      for (const Delivery& deliver : encoder_link.due(t)) deliver(t);
      for (const Delivery& deliver : camera_link.due(t)) deliver(t);
      const WheelDuties d = run.update(t);
      if (tap) {
        const std::string phase = std::string("wheels/") + wheels::name(run.stage());
        if (phase != last_phase) tap->phase(t, phase);
        last_phase = phase;
        tap->command(t, d);
      }
      command_link.push(t, d);
      for (const WheelDuties& c : command_link.due(t)) simulation.setDuty(c.left, c.right);
      simulation.advance(control_dt);
      if (options.trace &&
          (run.stage() != last_stage || run.estimator().history().size() != last_iterations)) {
        const Pose2D p = simulation.pose();
        std::fprintf(stderr, "t %.2f pose (%.3f, %.3f, %.2f deg): %s\n", t, p.x_m, p.y_m,
                     p.yaw_rad * 180 / M_PI, run.describe().c_str());
        last_stage = run.stage();
        last_iterations = run.estimator().history().size();
      }
    }
  } catch (const CalibrationError& e) {
    out.failure = e.what();
  }
  simulation.setDuty(0, 0);
  out.done = run.done();
  out.sim_s = simulation.time_s();
  out.end_pose = simulation.pose();
  out.iterations = run.estimator().history();
  out.result = run.result();
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
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
