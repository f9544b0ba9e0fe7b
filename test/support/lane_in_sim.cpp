#include "support/lane_in_sim.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"

namespace autocal {
namespace test {

LaneInSim::LaneInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                     const wheels::KinematicsParams& kinematics, const LaneInSimOptions& options)
    : robot_(robot),
      world_(world),
      kinematics_(kinematics),
      options_(options),
      rng_(options.seed) {}

LanePassInSim LaneInSim::runPass(wheels::LaneRefiner& refiner, const Pose2D& start) {
  const auto wall0 = std::chrono::steady_clock::now();
  sim::WorldConfig world = world_;
  world.robot_start = start;
  sim::Simulation simulation(robot_, world, sim::SimulationOptions());
  sim::RenderOptions render;
  render.supersampling = robot_.camera.supersampling;
  render.noise_sigma = robot_.camera.noise_sigma;
  render.noise_seed = options_.seed + static_cast<uint64_t>(clock_s_ * 1000);
  sim::Renderer renderer(robot_.camera, world, render);

  LanePassInSim out;
  const size_t passes_before = refiner.passes().size();
  const double control_dt = 1.0 / options_.control_rate_hz;
  const double frame_dt = 1.0 / robot_.camera.rate_hz;
  const double encoder_dt = 1.0 / robot_.encoder_rate_hz;
  double next_frame = 0, next_encoder = 0;
  const double t0 = clock_s_;
  wheels::LanePhase last_phase = refiner.phase();
  size_t last_parts = 0;
  while (simulation.time_s() < options_.max_pass_sim_s) {
    const double ts = simulation.time_s();
    const double t = t0 + ts;  // the refiner's clock carries on across passes
    const Pose2D p = simulation.pose();
    out.max_abs_lateral_any_m = std::max(out.max_abs_lateral_any_m, std::abs(p.y_m));
    if (ts >= next_encoder) {
      refiner.addEncoders(t, left_offset_ + simulation.encoderTicks(sim::Side::kLeft),
                          right_offset_ + simulation.encoderTicks(sim::Side::kRight),
                          robot_.encoder_resolution);
      next_encoder += encoder_dt;
    }
    if (ts >= next_frame) {
      refiner.addFrame(
          t, sim::renderFrame(renderer, simulation, ts, options_.max_blur_samples, rng_));
      ++out.frames;
      next_frame += frame_dt;
    }
    const wheels::LaneOutput o = refiner.update(t);
    if (o.apply) {
      kinematics_.trim = o.trim;
      out.applied = true;
      out.applied_trim = o.trim;
    }
    if (refiner.passes().size() > passes_before) break;
    WheelDuties d;
    if (o.commanding) {
      out.max_abs_lateral_m = std::max(out.max_abs_lateral_m, std::abs(p.y_m));
      d = wheels::carCmdToDuties(kinematics_, o.cmd);
    } else {
      // The lane follower's stand-in (it sees the lane lines; here the truth): steer towards the
      // lane centre, y = 0, heading 0, through the same kinematics.
      const double omega = -options_.follower_gain_y * p.y_m -
                           options_.follower_gain_yaw * std::remainder(p.yaw_rad, 2 * M_PI);
      d = wheels::carCmdToDuties(kinematics_, options_.follower_speed_mps, omega);
    }
    simulation.setDuty(d.left, d.right);
    simulation.advance(control_dt);
    if (options_.trace) {
      const size_t parts = refiner.currentPass().parts.size();
      if (refiner.phase() != last_phase || parts != last_parts) {
        std::fprintf(stderr, "t %.2f pose (%.3f, %.3f, %.2f deg): %s\n", t, p.x_m, p.y_m,
                     p.yaw_rad * 180 / M_PI, refiner.describe().c_str());
        last_phase = refiner.phase();
        last_parts = parts;
      }
    }
  }
  out.ended = refiner.passes().size() > passes_before;
  if (out.ended) out.pass = refiner.passes().back();
  out.end_pose = simulation.pose();
  out.sim_s = simulation.time_s();
  clock_s_ = t0 + simulation.time_s() + 1.0;
  left_offset_ += simulation.encoderTicks(sim::Side::kLeft);
  right_offset_ += simulation.encoderTicks(sim::Side::kRight);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return out;
}

}  // namespace test
}  // namespace autocal
