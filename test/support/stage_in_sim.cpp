#include "support/stage_in_sim.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <random>

#include "autocal/errors.h"
#include "autocal/sim/transport.h"

namespace autocal {
namespace test {

namespace {
double threadCpuMs() {
  timespec c;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c);
  return c.tv_sec * 1e3 + c.tv_nsec * 1e-6;
}
}  // namespace

sim::Renderer robotRenderer(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                            uint64_t seed) {
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  render.noise_seed = seed;
  return sim::Renderer(robot.camera, world, render);
}

double trueYawRateRadS(const sim::Simulation& simulation, const sim::RobotConfig& robot,
                       double capture_s) {
  const double frame_s = 1.0 / robot.camera.rate_hz;
  const std::vector<sim::Pose2> p = simulation.posesDuring(capture_s - frame_s, capture_s, 2);
  return std::abs(std::remainder(p.back().yaw_rad - p.front().yaw_rad, 2 * M_PI)) / frame_s;
}

StageInSim runStageInSim(Stage& stage, sim::Simulation& simulation, const sim::RobotConfig& robot,
                         sim::Renderer* renderer, const StageInSimOptions& options) {
  const auto wall0 = std::chrono::steady_clock::now();
  std::mt19937_64 rng(options.seed);
  StageInSim out;
  const double control_dt = 1.0 / options.control_rate_hz;
  const double frame_dt = 1.0 / robot.camera.rate_hz;
  const double encoder_dt = 1.0 / robot.encoder_rate_hz;
  double next_frame = simulation.time_s(), next_encoder = simulation.time_s(),
         next_range = simulation.time_s();
  const double range_dt = 1.0 / robot.range_sensor.rate_hz;
  WheelDuties previous;  // command_one_step_late: the last step's command
  bool first_step = true;
  const double end_s = simulation.time_s() + options.max_sim_s;
  RecordingTap* tap = options.tap;
  std::string last_phase;
  // A reading or frame is delivered (and the frame rendered, from the pose history) at its
  // release time, with its capture stamp; a command reaches the motors late.
  using Delivery = std::function<void(double now_s)>;
  const sim::LinkConfig none;
  sim::DelayQueue<Delivery> encoder_link(options.transport ? robot.transport.encoders : none,
                                         options.seed * 8 + 4);
  sim::DelayQueue<Delivery> camera_link(options.transport ? robot.transport.camera : none,
                                        options.seed * 8 + 3);
  sim::DelayQueue<WheelDuties> command_link(options.transport ? robot.transport.wheels_cmd : none,
                                            options.seed * 8 + 7);
  try {
    while (simulation.time_s() < end_s && !stage.done()) {
      const double t = simulation.time_s();
      if (options.before_step) options.before_step(t);
      if (t >= next_encoder) {
        std::int32_t left = simulation.encoderTicks(sim::Side::kLeft);
        std::int32_t right = simulation.encoderTicks(sim::Side::kRight);
        if (options.encoders) options.encoders(t, left, right);
        encoder_link.push(t, [&, t, left, right](double now) {
          stage.addEncoders(t, left, right, robot.encoder_resolution, now);
          if (tap) tap->encoders(t, left, right, robot.encoder_resolution);
        });
        next_encoder += encoder_dt;
      }
      if (renderer && t >= next_frame) {
        camera_link.push(t, [&, t](double now) {
          stage.noteFrameArrived(now);
          const bool stage_wants = stage.wantsFrame(t), tap_wants = tap && tap->wantsFrame(t);
          if (!stage_wants && !tap_wants) return;
          const cv::Mat image =
              sim::renderFrame(*renderer, simulation, t, options.max_blur_samples, rng);
          if (tap_wants) tap->frame(t, image);
          if (!stage_wants) return;
          ++out.frames_processed;
          const double c0 = threadCpuMs();
          const bool taken = stage.addFrame(t, image, "sim@" + std::to_string(t));
          out.frame_ms.push_back(threadCpuMs() - c0);
          if (options.after_frame) options.after_frame(t, taken);
        });
        next_frame += frame_dt;
      }
      for (const Delivery& deliver : encoder_link.due(t)) deliver(t);
      if (options.range_rng && t >= next_range) {
        double range = simulation.measureRange(*options.range_rng);
        if (options.range) options.range(t, range);
        stage.addRange(t, range);
        next_range += range_dt;
      }
      for (const Delivery& deliver : camera_link.due(t)) deliver(t);
      if (options.before_update) options.before_update(t);
      const WheelDuties d = stage.update(t);
      if (options.after_update) options.after_update(t, d);
      if (tap) {
        const std::string phase = options.phase ? options.phase() : "";
        if (phase != last_phase) tap->phase(t, phase);
        last_phase = phase;
        tap->command(t, d);
      }
      // One step late: the first step's command goes out at once (there is none before it).
      command_link.push(t, options.command_one_step_late && !first_step ? previous : d);
      previous = d;
      first_step = false;
      for (const WheelDuties& c : command_link.due(t)) simulation.setDuty(c.left, c.right);
      simulation.advance(control_dt);
      const double stalled_s = options.world_runs_on_s ? options.world_runs_on_s(t) : 0.0;
      if (stalled_s > 0) {
        simulation.advance(stalled_s);
        next_frame = std::max(next_frame, simulation.time_s());
        next_encoder = std::max(next_encoder, simulation.time_s());
        next_range = std::max(next_range, simulation.time_s());
      }
      if (options.after_step) options.after_step(t);
    }
  } catch (const Error& e) {
    out.failure = e.what();
  }
  simulation.setDuty(0, 0);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return out;
}

}  // namespace test
}  // namespace autocal
