// make bench, odometry section: the UAH method (odometry::UahRun, paper 002 §2) and UMBmark
// (odometry::UmbmarkRun, Borenstein & Feng) driven by the robot on the simulator's core (no ROS),
// per robot config, side by side with the truth of the robot config: Ed, the wheelbase and the
// distance per pulse; the simulated time and the floor each needs; and what each correction does
// to UMBmark's E_max,syst (a fresh UMBmark run on the corrected odometry). Prints Markdown.
#include <cmath>
#include <cstdio>
#include <string>

#include "support/odometry_in_sim.h"

using namespace autocal;

namespace {

sim::WorldConfig world(const std::string& name) {
  return sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/" + name);
}

std::string pct(double value, double truth) {
  char b[32];
  std::snprintf(b, sizeof b, "%+.2f %%", 100 * (value / truth - 1));
  return b;
}

/// E_max,syst [m] of a fresh UMBmark run on `odometry` (NaN when it did not drive every square).
double emaxWith(const test::OdometryTestRobot& r, const odometry::DiffDriveParams& odometry) {
  sim::Simulation simulation(r.robot, world("world_straight.yaml"), sim::SimulationOptions());
  odometry::UmbmarkRunOptions options;
  options.nominal = odometry;
  const test::UmbmarkInSim run = test::runUmbmarkInSim(simulation, options);
  const size_t n = static_cast<size_t>(options.runs_per_direction);
  if (run.cw.size() != n || run.ccw.size() != n) return NAN;
  return odometry::umbmarkEmaxSyst(run.cw, run.ccw);
}

}  // namespace

int main() {
  std::printf("### UAH vs UMBmark\n\n");
  std::printf(
      "Both methods driven by the robot itself on the simulator's core (no ROS; the node's 50 Hz "
      "loop, a command one cycle late), per robot, from the nominal Duckietown radius and "
      "wheelbase (0.0318 m, 0.1 m; the large robot 0.05 m, 0.29 m). **UAH**: 2 pivot experiments "
      "per wheel of 3 rounds, a spin, 2 straight runs of 3 m in `world_odometry.yaml`, each run's "
      "length from the truth. **UMBmark**: 5 squares of 1 m each way on an empty floor, each "
      "return error from the truth, corrected expressions. Truth from the robot config: Ed = "
      "r_R/r_L, b, c = 2π·r/135 per pulse.\n\n");
  std::printf(
      "| robot | method | Ed (error) | wheelbase [m] (error) | c_L / c_R [mm/pulse] (errors) | "
      "sim s | floor [m] | E_max,syst after its correction [mm] |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const test::OdometryTestRobot& r : test::odometryTestRobots()) {
    const sim::RobotConfig& robot = r.robot;
    const double c = 2 * M_PI / robot.encoder_resolution;
    const double true_cL = c * robot.wheel_radius_left, true_cR = c * robot.wheel_radius_right;
    const odometry::DiffDriveParams nominal = odometry::DiffDriveParams::fromWheel(
        2 * r.nominal_radius_m, robot.encoder_resolution, r.nominal_wheelbase_m);
    const double e_nominal = emaxWith(r, nominal);
    std::printf("| %s | truth | %.5f | %.4f | %.4f / %.4f | | | nominal: %.1f |\n", r.label.c_str(),
                test::trueEd(robot), robot.wheelbase, 1000 * true_cL, 1000 * true_cR,
                1000 * e_nominal);

    sim::Simulation uah_sim(robot, world("world_odometry.yaml"), sim::SimulationOptions());
    odometry::UahRunOptions uah_options;
    uah_options.nominal = nominal;
    uah_options.detection.min_range_m = 0.03;
    uah_options.detection.max_range_m = 2.0;
    std::mt19937_64 rng(1);
    const test::UahInSim uah = test::runUahInSim(uah_sim, uah_options, rng);
    if (uah.done) {
      const odometry::DiffDriveParams& cal = uah.result.calibrated;
      std::printf(
          "| | UAH | %.5f (%s) | %.4f (%s) | %.4f / %.4f (%s / %s) | %.0f | %.1f x %.1f | %.1f |\n",
          uah.result.ed.Ed, pct(uah.result.ed.Ed, test::trueEd(robot)).c_str(), cal.wheelbase_m,
          pct(cal.wheelbase_m, robot.wheelbase).c_str(), 1000 * cal.left_m_per_pulse,
          1000 * cal.right_m_per_pulse, pct(cal.left_m_per_pulse, true_cL).c_str(),
          pct(cal.right_m_per_pulse, true_cR).c_str(), uah.sim_s, uah.floor.widthM(),
          uah.floor.heightM(), 1000 * emaxWith(r, cal));
    } else {
      std::printf("| | UAH | failed: %s | | | %.0f | | |\n", uah.failure.c_str(), uah.sim_s);
    }

    sim::Simulation umb_sim(robot, world("world_straight.yaml"), sim::SimulationOptions());
    odometry::UmbmarkRunOptions umb_options;
    umb_options.nominal = nominal;
    const test::UmbmarkInSim umb = test::runUmbmarkInSim(umb_sim, umb_options);
    if (umb.done) {
      const odometry::DiffDriveParams cal =
          odometry::applyUmbmarkCorrection(nominal, umb.result.Ed, umb.result.Eb);
      // UMBmark keeps the mean distance per pulse nominal: its wheelbase and c are in the
      // nominal scale (errors against the truth include the nominal radius's error).
      std::printf(
          "| | UMBmark | %.5f (%s) | %.4f (%s) | %.4f / %.4f (%s / %s) | %.0f | %.1f x %.1f | %.1f "
          "|\n",
          umb.result.Ed, pct(umb.result.Ed, test::trueEd(robot)).c_str(), cal.wheelbase_m,
          pct(cal.wheelbase_m, robot.wheelbase).c_str(), 1000 * cal.left_m_per_pulse,
          1000 * cal.right_m_per_pulse, pct(cal.left_m_per_pulse, true_cL).c_str(),
          pct(cal.right_m_per_pulse, true_cR).c_str(), umb.sim_s, umb.floor.widthM(),
          umb.floor.heightM(), 1000 * emaxWith(r, cal));
    } else {
      std::printf("| | UMBmark | failed: %s | | | %.0f | | |\n", umb.failure.c_str(), umb.sim_s);
    }
    std::fflush(stdout);
  }
  std::printf(
      "\n\"floor\": the box the robot's footprint swept (UAH: the pivots in the room and the 3 m "
      "line; UMBmark: the squares, which wander as an uncorrected robot's heading drifts between "
      "runs). UMBmark measures no absolute scale: its wheelbase and distances per pulse keep the "
      "nominal mean distance per pulse, so their errors include the nominal radius's own error "
      "(Ed, and the wheelbase in pulses, Eb, are what it determines). "
      "\"E_max,syst after its correction\": a fresh UMBmark run (5 squares each way) on the "
      "odometry each method wrote; \"nominal\": before any correction.\n\n"
      "Reproduce: `make build && taskset -c 0 build/bench/odometry_bench` (or "
      "`scripts/bench/odometry.sh`).\n");
  return 0;
}
