// See odometry_in_sim.h.
#include "support/odometry_in_sim.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

namespace {

constexpr double kControlDt = 0.02;

/// The odometry node's loop: 50 Hz, a command applied one cycle after the readings it came from,
/// no frames, the readings at once.
StageInSimOptions odometryLoop(double max_sim_s) {
  StageInSimOptions o;
  o.control_rate_hz = 1.0 / kControlDt;
  o.max_sim_s = max_sim_s;
  o.transport = false;
  o.command_one_step_late = true;
  return o;
}

sim::RobotConfig variant(double radius_left, double radius_right, double wheelbase,
                         double gain_left, double gain_right, double deadband) {
  sim::RobotConfig r =
      sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml");
  r.wheel_radius_left = radius_left;
  r.wheel_radius_right = radius_right;
  r.wheelbase = wheelbase;
  r.motor_gain_left = gain_left;
  r.motor_gain_right = gain_right;
  r.deadband = deadband;
  return r;
}

/// The node's output of one control cycle: the command, and the status when its key changed.
void record(odometry::UahRecording& rec, const odometry::UahRun& run, double t,
            const WheelDuties& d, std::string* key) {
  rec.commands.push_back({t, d.left, d.right});
  const std::string phase = std::string("odometry/") + odometry::name(run.experiment());
  const std::string k = phase + "/" + std::to_string(run.round()) + "/" +
                        std::to_string(run.straightRun()) + "/" +
                        std::to_string(run.needsStraightLength());
  if (k == *key) return;
  *key = k;
  odometry::UahRecording::Status s;
  s.stamp_s = t;
  s.phase = phase;
  s.state = run.done() ? 2 : run.failed() ? 3 : 1;
  s.failure_reason = run.failure();
  s.round = run.round();
  s.straight_run = run.straightRun();
  rec.statuses.push_back(s);
}

}  // namespace

void FloorBox::add(const sim::RobotConfig& robot, const Pose2D& pose) {
  const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
  for (int i = 0; i < 4; ++i) {
    const double fx = robot.chassis_offset_x_m + (i & 1 ? 0.5 : -0.5) * robot.chassis_length_m;
    const double fy = (i & 2 ? 0.5 : -0.5) * robot.chassis_width_m;
    const double x = pose.x_m + c * fx - s * fy, y = pose.y_m + s * fx + c * fy;
    min_x_m = std::min(min_x_m, x), max_x_m = std::max(max_x_m, x);
    min_y_m = std::min(min_y_m, y), max_y_m = std::max(max_y_m, y);
  }
}

UahInSim runUahInSim(sim::Simulation& simulation, const odometry::UahRunOptions& options,
                     std::mt19937_64& rng, double max_sim_s, const UahSensorHooks& hooks) {
  const sim::RobotConfig& robot = simulation.robot();
  const bool trace = std::getenv("AUTOCAL_TRACE") != nullptr;
  const bool trace_straight = std::getenv("AUTOCAL_TRACE_STRAIGHT") != nullptr;
  UahInSim out;
  odometry::UahRun run(options);
  const double t0 = simulation.time_s();
  const double start_yaw = simulation.pose().yaw_rad;
  Pose2D run_start;
  bool was_driving = false, driving = false;
  std::string last, status_key;
  StageInSimOptions o = odometryLoop(max_sim_s);
  o.transport = hooks.transport;
  o.range_rng = &rng;
  o.encoders = [&](double t, std::int32_t& left, std::int32_t& right) {
    if (hooks.encoders) hooks.encoders(t, left, right);
    if (hooks.recording) hooks.recording->encoders.push_back({t, left, right});
  };
  o.range = [&](double t, double& range) {
    if (hooks.range) hooks.range(t, range, rng);
    if (hooks.recording) hooks.recording->ranges.push_back({t, range});
  };
  o.before_update = [&](double t) {
    // The straight run's true length: the axle centre's start-to-end distance (the helper that
    // stands for the tape measure).
    driving = run.experiment() == odometry::UahExperiment::kStraight && !run.needsStraightLength();
    if (driving && !was_driving) {
      run_start = simulation.pose();
      // Only the forward runs: a run back starts where the one before ended, turned by its drift.
      if (run.straightRun() % 2 == 1) {
        out.straight_start_yaw_rad.push_back(
            std::remainder(run_start.yaw_rad - start_yaw, 2 * M_PI));
      }
    }
    was_driving = driving;
    if (!run.needsStraightLength()) return;
    const Pose2D p = simulation.pose();
    const double length = std::hypot(p.x_m - run_start.x_m, p.y_m - run_start.y_m);
    const double given = hooks.straight_length ? hooks.straight_length(length) : length;
    if (hooks.recording) hooks.recording->lengths.push_back({t, given});
    run.setStraightLength(given);
    was_driving = false;
  };
  o.after_update = [&](double t, const WheelDuties& d) {
    if (hooks.recording) record(*hooks.recording, run, t, d, &status_key);
    if (trace_straight && driving &&
        (std::getenv("AUTOCAL_TRACE_ALL") || std::fmod(t, 0.25) < kControlDt / 2)) {
      const Pose2D p = simulation.pose();
      std::fprintf(stderr, "  t %.2f (%.3f, %.3f, %.2f deg) duties %.3f %.3f ticks %d %d\n", t,
                   p.x_m, p.y_m, p.yaw_rad * 180 / M_PI, d.left, d.right,
                   simulation.encoderTicks(sim::Side::kLeft),
                   simulation.encoderTicks(sim::Side::kRight));
    }
  };
  o.after_step = [&](double t) {
    out.floor.add(robot, simulation.pose());
    if (trace && run.describe().substr(0, 12) != last.substr(0, 12)) {
      const Pose2D p = simulation.pose();
      std::fprintf(stderr, "t %.1f pose (%.3f, %.3f, %.1f deg): %s\n", t, p.x_m, p.y_m,
                   p.yaw_rad * 180 / M_PI, run.describe().c_str());
    }
    if (trace) last = run.describe();
  };
  const StageInSim r = runStageInSim(run, simulation, robot, nullptr, o);
  out.failure = r.failure;
  out.done = run.done();
  if (out.done) out.result = run.result();
  out.turns = run.turns();
  out.face_turns = run.faceTurns();
  out.straight_runs = run.straightRuns();
  out.sim_s = simulation.time_s() - t0;
  out.wall_s = r.wall_s;
  return out;
}

UmbmarkInSim runUmbmarkInSim(sim::Simulation& simulation,
                             const odometry::UmbmarkRunOptions& options, double max_sim_s) {
  const sim::RobotConfig& robot = simulation.robot();
  const bool trace = std::getenv("AUTOCAL_TRACE") != nullptr;
  UmbmarkInSim out;
  odometry::UmbmarkRun run(options);
  const double t0 = simulation.time_s();
  Pose2D run_start = simulation.pose();
  bool was_moving = false;
  StageInSimOptions o = odometryLoop(max_sim_s);
  o.before_update = [&](double t) {
    if (!run.needsReturnError()) return;
    // The run's end relative to its start, in the start's frame, minus the computed end.
    const Pose2D p = simulation.pose();
    const double dx = p.x_m - run_start.x_m, dy = p.y_m - run_start.y_m;
    const double c = std::cos(run_start.yaw_rad), s = std::sin(run_start.yaw_rad);
    const Pose2D computed = run.computedPose();
    const odometry::ReturnError e{c * dx + s * dy - computed.x_m, -s * dx + c * dy - computed.y_m};
    if (trace) {
      std::fprintf(stderr, "t %.1f %s: error (%.4f, %.4f) m, computed (%.4f, %.4f)\n", t,
                   run.describe().c_str(), e.x_m, e.y_m, computed.x_m, computed.y_m);
    }
    run.setReturnError(e);
    was_moving = false;
  };
  o.after_update = [&](double, const WheelDuties& d) {
    // A run starts at its first duties; the robot still stands where the last one stopped.
    const bool moving = run.phase() == odometry::UmbmarkPhase::kClockwise ||
                        run.phase() == odometry::UmbmarkPhase::kCounterClockwise;
    if (moving && !was_moving && (d.left != 0 || d.right != 0)) {
      run_start = simulation.pose();
      was_moving = true;
    }
  };
  o.after_step = [&](double) { out.floor.add(robot, simulation.pose()); };
  const StageInSim r = runStageInSim(run, simulation, robot, nullptr, o);
  out.failure = r.failure;
  out.done = run.done();
  if (out.done) out.result = run.result();
  out.cw = run.clockwiseErrors();
  out.ccw = run.counterClockwiseErrors();
  out.sim_s = simulation.time_s() - t0;
  out.wall_s = r.wall_s;
  return out;
}

sim::RobotConfig stickyLateRobot() {
  sim::RobotConfig robot =
      sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot.yaml");
  robot.deadband = 0.074;
  robot.breakaway_duty_left = 0.097;
  robot.breakaway_duty_right = 0.098;
  robot.backlash_rad = 0.055;
  robot.backward_gain_ratio_left = 0.955;
  robot.backward_gain_ratio_right = 1.024;
  robot.transport.encoders.latency_s = robot.transport.wheels_cmd.latency_s = 0.05;
  return robot;
}

std::vector<OdometryTestRobot> odometryTestRobots() {
  std::vector<OdometryTestRobot> robots;
  robots.push_back(
      {"default (robot_ideal.yaml: r_R +1.3 %, b 0.102)",
       sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml"),
       0.0318, 0.1});
  robots.push_back(
      {"left wheel +2 %, b 0.109", variant(0.0325, 0.03185, 0.109, 0.95, 1.0, 0.12), 0.0318, 0.1});
  robots.push_back(
      {"right wheel +1.9 %, b 0.100", variant(0.0314, 0.0320, 0.100, 1.0, 0.9, 0.05), 0.0318, 0.1});
  // Nothing tied to the Duckiebot: wheelbase 0.3 m, radius 0.05 m, a bigger chassis.
  sim::RobotConfig large = variant(0.0500, 0.0504, 0.300, 1.0, 0.97, 0.08);
  large.chassis_length_m = 0.40;
  large.chassis_width_m = 0.36;
  large.chassis_offset_x_m = -0.08;
  large.caster_x_m = -0.22;
  large.mass_kg = 4.0;
  large.range_sensor.x_m = 0.12;
  robots.push_back({"large (r 0.05, b 0.30)", large, 0.05, 0.29});
  return robots;
}

double trueEd(const sim::RobotConfig& robot) {
  return robot.wheel_radius_right / robot.wheel_radius_left;
}

double trueEb(const sim::RobotConfig& robot, double nominal_radius_m, double nominal_wheelbase_m) {
  const double mean_radius = 0.5 * (robot.wheel_radius_left + robot.wheel_radius_right);
  return (robot.wheelbase / mean_radius) / (nominal_wheelbase_m / nominal_radius_m);
}

}  // namespace test
}  // namespace autocal
