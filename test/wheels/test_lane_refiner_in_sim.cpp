// The in-lane refinement (paper 000 §5.2) on the simulator's core, judged by the simulator's truth:
// the default robot drives sim/config/world_lane.yaml's segment pass after pass with a trim off by
// ±0.05; the trim applied ends within 0.01 of the true one, and the robot's true path stays between
// the lane lines. A trim already right is left as it is.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "autocal/sim/config.h"
#include "support/lane_in_sim.h"

using namespace autocal;

namespace {

// Half the lane (0.23 m between the lines' inner edges) minus half the robot (0.13 m wide).
constexpr double kMaxLateralM = 0.115 - 0.065;

sim::RobotConfig robotConfig() {
  return sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml");
}
sim::WorldConfig laneWorld() {
  return sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world_lane.yaml");
}

/// The trim that drives the simulated robot straight: right/left true speed factor k =
/// (g_l·R_l)/(g_r·R_r) at equal commands, trim = gain·(k − 1)/(k + 1).
double trueTrim(const sim::RobotConfig& r, double gain) {
  const double k =
      (r.motor_gain_left * r.wheel_radius_left) / (r.motor_gain_right * r.wheel_radius_right);
  return gain * (k - 1) / (k + 1);
}

struct Outcome {
  std::vector<test::LanePassInSim> passes;
  double final_trim = 0;
  int applications = 0;
  int first_applied_pass = -1;  // 1-based
  double max_lateral_m = 0;
  double wall_s = 0;
};

Outcome drivePasses(double trim_offset, int passes) {
  sim::RobotConfig robot = robotConfig();
  // 15 frames/s instead of 30: half the rendering and detection (the test's wall time), and each
  // straight part still has about 9 frames.
  robot.camera.rate_hz = 15.0;
  wheels::LaneRefinerOptions o;
  // The wheel stage's result for this robot: its deadbands compensated (the true 0.08), the trim
  // off by trim_offset.
  o.kinematics.deadband_left = o.kinematics.deadband_right = robot.deadband;
  o.kinematics.trim = trueTrim(robot, o.kinematics.gain) + trim_offset;
  o.first_tag_id = 100;
  o.num_tags = 8;
  wheels::LaneRefiner refiner(o, robot.camera.truth);
  test::LaneInSimOptions so;
  so.trace = std::getenv("AUTOCAL_TRACE") != nullptr;
  test::LaneInSim lane(robot, laneWorld(), o.kinematics, so);
  // Each pass starts somewhere else in the lane, as a lane follower would bring the robot.
  const Pose2D starts[] = {{0.0, 0.0, 0.0},      {-0.1, 0.015, 0.03}, {0.0, -0.015, -0.03},
                           {-0.05, 0.01, -0.02}, {0.0, -0.01, 0.02},  {0.0, 0.0, 0.0}};
  Outcome out;
  for (int i = 0; i < passes; ++i) {
    test::LanePassInSim p = lane.runPass(refiner, starts[i % 6]);
    out.wall_s += p.wall_s;
    out.max_lateral_m = std::max(out.max_lateral_m, p.max_abs_lateral_m);
    if (p.applied && out.first_applied_pass < 0) out.first_applied_pass = i + 1;
    std::printf(
        "pass %d: %s, %zu parts, estimate %.5f (true %.5f), applied %s %.5f, max |y| %.1f "
        "mm (commanding) %.1f mm (any), end x %.2f, sim %.1f s, wall %.1f s, %d frames\n",
        i + 1,
        !p.ended         ? "did not end"
        : p.pass.aborted ? ("aborted: " + p.pass.reason).c_str()
                         : "ended",
        p.pass.parts.size(), p.pass.estimate, trueTrim(robot, o.kinematics.gain),
        p.applied ? "yes" : "no", p.applied_trim, p.max_abs_lateral_m * 1000,
        p.max_abs_lateral_any_m * 1000, p.end_pose.x_m, p.sim_s, p.wall_s, p.frames);
    out.passes.push_back(p);
  }
  out.final_trim = lane.kinematics().trim;
  out.applications = refiner.applications();
  return out;
}

int passesFromEnv(int n) {
  return std::getenv("LANE_PASSES") ? std::atoi(std::getenv("LANE_PASSES")) : n;
}

void expectConverged(const Outcome& o, int max_first_applied_pass) {
  const double truth = trueTrim(robotConfig(), 1.0);
  for (const auto& p : o.passes) {
    ASSERT_TRUE(p.ended);
    EXPECT_FALSE(p.pass.aborted) << p.pass.reason;
  }
  EXPECT_EQ(o.applications, 1);
  EXPECT_GE(o.first_applied_pass, 1);
  EXPECT_LE(o.first_applied_pass, max_first_applied_pass);
  EXPECT_NEAR(o.final_trim, truth, 0.01);
  EXPECT_LT(o.max_lateral_m, kMaxLateralM);
  std::printf(
      "trim %.5f, true %.5f, error %+.5f; applied at pass %d; max |y| %.1f mm; wall %.1f s\n",
      o.final_trim, truth, o.final_trim - truth, o.first_applied_pass, o.max_lateral_m * 1000,
      o.wall_s);
}

}  // namespace

TEST(LaneRefinerInSim, TrimOffByPlus005Converges) {
  // Four passes: the third applies (three agreeing estimates), the fourth agrees with it and
  // changes nothing.
  expectConverged(drivePasses(+0.05, passesFromEnv(4)), 3);
}

TEST(LaneRefinerInSim, TrimOffByMinus005Converges) {
  expectConverged(drivePasses(-0.05, passesFromEnv(3)), 3);
}

TEST(LaneRefinerInSim, RightTrimIsNotChanged) {
  const Outcome o = drivePasses(0.0, passesFromEnv(3));
  for (const auto& p : o.passes) {
    ASSERT_TRUE(p.ended);
    EXPECT_TRUE(p.pass.estimated) << p.pass.reason;
  }
  EXPECT_EQ(o.applications, 0);
  EXPECT_EQ(o.final_trim, trueTrim(robotConfig(), 1.0));
  EXPECT_LT(o.max_lateral_m, kMaxLateralM);
  std::printf("not changed: max |y| %.1f mm; wall %.1f s\n", o.max_lateral_m * 1000, o.wall_s);
}
