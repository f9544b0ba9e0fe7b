// UMBmark driven by the robot (odometry::UmbmarkRun) on the simulator's core, no ROS, judged by the
// truth the test reads from the robot config; the run sees only its encoders and, after each
// square, the return error (here from the simulator's pose, as the ground-truth helper gives it
// through ROS). Targets: Ed and Eb within 0.5 % of the truth; after the correction,
// E_max,syst of a fresh UMBmark run at least 10× smaller; UAH and UMBmark agree within their
// tolerances on the same robot. Bad input: encoder jumps, stalls, absurd errors — clear reasons.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "autocal/errors.h"
#include "autocal/odometry/umbmark_run.h"
#include "support/odometry_in_sim.h"

using namespace autocal;
using test::OdometryTestRobot;
using test::trueEb;
using test::trueEd;

namespace {

sim::WorldConfig world(const std::string& name) {
  return sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/" + name);
}

odometry::UmbmarkRunOptions umbmarkOptions(const sim::RobotConfig& robot, double radius_m,
                                           double wheelbase_m) {
  odometry::UmbmarkRunOptions o;
  o.nominal =
      odometry::DiffDriveParams::fromWheel(2 * radius_m, robot.encoder_resolution, wheelbase_m);
  return o;
}

struct Checked {
  odometry::UmbmarkResult result;
  double e_Ed = 0, e_Eb = 0;
};

/// UMBmark, then a fresh UMBmark run on the corrected odometry, on one simulated robot (the empty
/// floor: the squares wander as the uncorrected robot's heading drifts).
Checked umbmarkAndVerify(const OdometryTestRobot& r) {
  sim::Simulation simulation(r.robot, world("world_straight.yaml"), sim::SimulationOptions());
  const odometry::UmbmarkRunOptions options =
      umbmarkOptions(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m);
  const test::UmbmarkInSim before = test::runUmbmarkInSim(simulation, options);
  Checked c;
  EXPECT_TRUE(before.done) << before.failure;
  if (!before.done) return c;
  c.result = before.result;
  const double Ed = trueEd(r.robot),
               Eb = trueEb(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m);
  c.e_Ed = before.result.Ed / Ed - 1;
  c.e_Eb = before.result.Eb / Eb - 1;
  std::printf(
      "[%s] UMBmark: Ed %.5f (true %.5f, %+.3f %%), Eb %.5f (true %.5f, %+.3f %%), E_max,syst "
      "%.1f mm; sim %.0f s, wall %.1f s, floor %.1f x %.1f m\n",
      r.label.c_str(), before.result.Ed, Ed, 100 * c.e_Ed, before.result.Eb, Eb, 100 * c.e_Eb,
      1000 * before.result.E_max_syst_m, before.sim_s, before.wall_s, before.floor.widthM(),
      before.floor.heightM());
  for (size_t i = 0; i < before.cw.size(); ++i) {
    std::printf("[%s]   cw %zu (%+.4f, %+.4f) m   ccw %zu (%+.4f, %+.4f) m\n", r.label.c_str(),
                i + 1, before.cw[i].x_m, before.cw[i].y_m, i + 1, before.ccw[i].x_m,
                before.ccw[i].y_m);
  }

  // The correction applied to the dead reckoning (c_L, c_R, b: the multipliers), then a fresh run
  // from where the robot stands. Its E_max,syst from the given errors (computeUmbmark may refuse
  // an Ed of 1 within precision, which is what a good correction gives).
  odometry::UmbmarkRunOptions corrected = options;
  corrected.nominal =
      odometry::applyUmbmarkCorrection(options.nominal, before.result.Ed, before.result.Eb);
  const test::UmbmarkInSim after = test::runUmbmarkInSim(simulation, corrected);
  EXPECT_EQ(after.cw.size(), static_cast<size_t>(options.runs_per_direction)) << after.failure;
  EXPECT_EQ(after.ccw.size(), static_cast<size_t>(options.runs_per_direction)) << after.failure;
  if (after.cw.empty() || after.ccw.empty()) return c;
  const double e_after = odometry::umbmarkEmaxSyst(after.cw, after.ccw);
  std::printf("[%s] E_max,syst before %.1f mm, after the correction %.1f mm (%.0fx smaller)\n",
              r.label.c_str(), 1000 * before.result.E_max_syst_m, 1000 * e_after,
              before.result.E_max_syst_m / e_after);
  EXPECT_LE(e_after * 10, before.result.E_max_syst_m);
  return c;
}

class UmbmarkRunInSim : public ::testing::TestWithParam<int> {};

TEST_P(UmbmarkRunInSim, FindsTheTrueWheelsAndItsCorrectionClosesTheSquare) {
  const OdometryTestRobot r = test::odometryTestRobots().at(GetParam());
  const Checked c = umbmarkAndVerify(r);
  EXPECT_LT(std::abs(c.e_Ed), 0.005) << r.label;
  EXPECT_LT(std::abs(c.e_Eb), 0.005) << r.label;
}

INSTANTIATE_TEST_SUITE_P(Robots, UmbmarkRunInSim, ::testing::Values(0, 1, 2, 3));

class UmbmarkAndUah : public ::testing::TestWithParam<int> {};

TEST_P(UmbmarkAndUah, AgreeOnTheSameRobot) {
  // Paper 002 §3: both methods on one robot. UAH in the odometry world (walls to correlate, a
  // 3 m line), UMBmark on an empty floor (it needs the square's room). They agree when their
  // difference is within the sum of their tolerances: Ed 0.2 % + 0.5 %; Eb (the wheelbase in
  // pulses) 0.5 % + 0.5 % for UAH's b and c̄ and UMBmark's Eb.
  const OdometryTestRobot r = test::odometryTestRobots().at(GetParam());
  sim::Simulation uah_sim(r.robot, world("world_odometry.yaml"), sim::SimulationOptions());
  odometry::UahRunOptions uah_options;
  uah_options.nominal = odometry::DiffDriveParams::fromWheel(
      2 * r.nominal_radius_m, r.robot.encoder_resolution, r.nominal_wheelbase_m);
  uah_options.detection.min_range_m = 0.03;
  uah_options.detection.max_range_m = 2.0;
  std::mt19937_64 rng(1);
  const test::UahInSim uah = test::runUahInSim(uah_sim, uah_options, rng);
  ASSERT_TRUE(uah.done) << uah.failure;
  sim::Simulation umb_sim(r.robot, world("world_straight.yaml"), sim::SimulationOptions());
  const test::UmbmarkInSim umb = test::runUmbmarkInSim(
      umb_sim, umbmarkOptions(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m));
  ASSERT_TRUE(umb.done) << umb.failure;

  const auto& cal = uah.result.calibrated;
  const double uah_Ed = uah.result.ed.Ed;
  const double c_nominal = uah_options.nominal.right_m_per_pulse;  // both wheels nominal alike
  const double uah_Eb = (cal.wheelbase_m / (0.5 * (cal.left_m_per_pulse + cal.right_m_per_pulse))) /
                        (uah_options.nominal.wheelbase_m / c_nominal);
  std::printf(
      "[%s] Ed: UAH %.5f, UMBmark %.5f, truth %.5f; Eb: UAH %.5f, UMBmark %.5f, truth %.5f; "
      "sim time UAH %.0f s, UMBmark %.0f s; floor UAH %.1f x %.1f m, UMBmark %.1f x %.1f m\n",
      r.label.c_str(), uah_Ed, umb.result.Ed, trueEd(r.robot), uah_Eb, umb.result.Eb,
      trueEb(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m), uah.sim_s, umb.sim_s,
      uah.floor.widthM(), uah.floor.heightM(), umb.floor.widthM(), umb.floor.heightM());
  EXPECT_LT(std::abs(uah_Ed / umb.result.Ed - 1), 0.002 + 0.005);
  EXPECT_LT(std::abs(uah_Eb / umb.result.Eb - 1), 0.005 + 0.005);
}

INSTANTIATE_TEST_SUITE_P(Robots, UmbmarkAndUah, ::testing::Values(0, 1, 2, 3));

// Bad input, on the core alone (fed by hand): each a clear reason, the run failed, zero duties.
odometry::UmbmarkRunOptions duckiebot() {
  odometry::UmbmarkRunOptions o;
  o.nominal = odometry::DiffDriveParams::fromWheel(0.0636, 135, 0.1);
  return o;
}

TEST(UmbmarkRun, AnEncoderResetIsAJump) {
  odometry::UmbmarkRun run(duckiebot());
  run.addEncoders(0.0, 50000, 51000);
  run.update(0.0);
  run.addEncoders(0.033, 50003, 51003);
  EXPECT_THROW(run.addEncoders(0.066, 0, 0), CalibrationError);
  EXPECT_TRUE(run.failed());
  EXPECT_NE(run.failure().find("encoder jump"), std::string::npos) << run.failure();
  const WheelDuties d = run.update(0.1);
  EXPECT_EQ(d.left, 0.0);
  EXPECT_EQ(d.right, 0.0);
}

TEST(UmbmarkRun, AStalledWheelFails) {
  odometry::UmbmarkRun run(duckiebot());
  double t = 0;
  std::string failure;
  try {
    for (; t < 10; t += 0.02) {
      run.addEncoders(t, 100, 100);  // commanded, never moving: blocked against a wall
      run.update(t);
    }
  } catch (const CalibrationError& e) {
    failure = e.what();
  }
  EXPECT_TRUE(run.failed());
  EXPECT_NE(failure.find("stalled"), std::string::npos) << failure;
  EXPECT_LT(t, 4.0);
}

TEST(UmbmarkRun, SilentEncodersFail) {
  odometry::UmbmarkRun run(duckiebot());
  run.addEncoders(0, 0, 0);
  run.update(0);
  EXPECT_THROW(
      {
        for (double t = 0.02; t < 5; t += 0.02) run.update(t);
      },
      CalibrationError);
  EXPECT_NE(run.failure().find("silent"), std::string::npos) << run.failure();
}

TEST(UmbmarkRun, ErrorsOnlyWhenAwaitedAndOfASensibleSize) {
  odometry::UmbmarkRun run(duckiebot());
  EXPECT_THROW(run.setReturnError({0.01, 0.02}), InputError);
  odometry::UmbmarkRunOptions bad = duckiebot();
  bad.side_m = 0.15;  // 1.5 wheelbases: the turns would not be separated from the legs
  try {
    odometry::UmbmarkRun r(bad);
    ADD_FAILURE() << "a 0.15 m square for a 0.1 m wheelbase was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("side_m"), std::string::npos) << e.what();
  }
}

TEST(UmbmarkRunInSimBadInput, AnErrorInCentimetresIsRefused) {
  // The simulator drives one square; the error given in centimetres is 100x too large.
  const OdometryTestRobot r = test::odometryTestRobots().at(0);
  sim::Simulation simulation(r.robot, world("world_straight.yaml"), sim::SimulationOptions());
  odometry::UmbmarkRun run(umbmarkOptions(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m));
  std::string failure;
  try {
    while (simulation.time_s() < 120 && !run.needsReturnError()) {
      run.addEncoders(simulation.time_s(), simulation.encoderTicks(sim::Side::kLeft),
                      simulation.encoderTicks(sim::Side::kRight));
      const WheelDuties d = run.update(simulation.time_s());
      simulation.setDuty(d.left, d.right);
      simulation.advance(0.02);
    }
    ASSERT_TRUE(run.needsReturnError()) << run.describe();
    run.setReturnError({-12.0, -25.0});
  } catch (const CalibrationError& e) {
    failure = e.what();
  }
  EXPECT_TRUE(run.failed());
  EXPECT_NE(failure.find("metres expected"), std::string::npos) << failure;
}

}  // namespace

namespace {

TEST(UmbmarkRunInSimErrorsAtTheEnd, GivesTheSameResultAsErrorsAfterEachSquare) {
  // The errors-file mode (~errors_file): every square driven first, pausing after each while a
  // person marks where the robot stopped; then all the errors at once, from a file the run reads
  // until it is whole. Here they come from the truth as each square ends; the result must be what
  // the per-square mode finds (test above).
  const OdometryTestRobot r = test::odometryTestRobots().at(0);
  sim::Simulation simulation(r.robot, world("world_straight.yaml"), sim::SimulationOptions());
  odometry::UmbmarkRunOptions options =
      umbmarkOptions(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m);
  options.runs_per_direction = 3;
  options.errors_after_all = true;
  options.run_pause_s = 2.0;
  const std::string errors_file = ::testing::TempDir() + "umbmark_errors_at_the_end.yaml";
  std::remove(errors_file.c_str());
  options.errors_file = errors_file;
  odometry::UmbmarkRun run(options);
  std::vector<odometry::ReturnError> cw, ccw;
  Pose2D start = simulation.pose();
  bool moving = false;
  size_t squares = 0;
  double paused_s = 0;
  while (simulation.time_s() < 600 && !run.needsAllReturnErrors()) {
    const double t = simulation.time_s();
    run.addEncoders(t, simulation.encoderTicks(sim::Side::kLeft),
                    simulation.encoderTicks(sim::Side::kRight));
    const WheelDuties d = run.update(t);
    if (!moving && (d.left != 0 || d.right != 0)) start = simulation.pose(), moving = true;
    if (!moving && squares > 0) paused_s += 0.02;
    if (run.computedEnds().size() > squares) {
      squares = run.computedEnds().size();
      const Pose2D p = simulation.pose(), computed = run.computedEnds().back();
      const double dx = p.x_m - start.x_m, dy = p.y_m - start.y_m;
      const double c = std::cos(start.yaw_rad), s = std::sin(start.yaw_rad);
      const odometry::ReturnError e{c * dx + s * dy - computed.x_m,
                                    -s * dx + c * dy - computed.y_m};
      (squares <= 3 ? cw : ccw).push_back(e);
      moving = false;
    }
    simulation.setDuty(d.left, d.right);
    simulation.advance(0.02);
  }
  ASSERT_TRUE(run.needsAllReturnErrors()) << run.describe();
  EXPECT_EQ(run.computedEnds().size(), 6u);
  EXPECT_GE(paused_s, 5 * 2.0 - 0.5) << "the robot did not pause between squares";
  EXPECT_THROW(run.setReturnErrors(cw, {}), InputError);  // counts must match the squares
  auto yaml = [](const std::vector<odometry::ReturnError>& errors) {
    std::string s = "[";
    for (const auto& e : errors)
      s +=
          (s.size() > 1 ? ", [" : "[") + std::to_string(e.x_m) + ", " + std::to_string(e.y_m) + "]";
    return s + "]";
  };
  double t = simulation.time_s();
  run.update(t += 1.5);  // no file yet: the run waits
  EXPECT_FALSE(run.done());
  EXPECT_NE(run.describe().find(errors_file), std::string::npos) << run.describe();
  {
    std::ofstream f(errors_file);
    // The person has measured one counter-clockwise square so far.
    f << "cw: " << yaml(cw) << "\nccw: " << yaml({ccw.front()}) << "\n";
  }
  run.update(t += 1.5);
  EXPECT_FALSE(run.done());
  EXPECT_NE(run.describe().find("3 cw and 1 ccw errors"), std::string::npos) << run.describe();
  {
    std::ofstream f(errors_file);
    f << "cw: " << yaml(cw) << "\nccw: " << yaml(ccw) << "\n";
  }
  run.update(t += 0.5);  // read at most once a second
  EXPECT_FALSE(run.done());
  run.update(t += 1.0);
  ASSERT_TRUE(run.done()) << run.failure() << " | " << run.describe();
  const double Ed = trueEd(r.robot),
               Eb = trueEb(r.robot, r.nominal_radius_m, r.nominal_wheelbase_m);
  std::printf("[errors at the end] Ed %.5f (true %.5f), Eb %.5f (true %.5f)\n", run.result().Ed, Ed,
              run.result().Eb, Eb);
  EXPECT_LT(std::abs(run.result().Ed / Ed - 1), 0.005);
  EXPECT_LT(std::abs(run.result().Eb / Eb - 1), 0.005);
}

}  // namespace
