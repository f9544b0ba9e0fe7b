#include "autocal/sim/straight_drift.h"

#include <cmath>

#include "autocal/sim/simulation.h"

namespace autocal {
namespace sim {

double straightDriftM(const RobotConfig& robot, const wheels::KinematicsParams& params,
                      double speed_mps, double distance_m) {
  WorldConfig empty;
  RobotConfig without_slip = robot;
  without_slip.wheel_slip_sigma = 0;
  Simulation simulation(without_slip, empty, SimulationOptions());
  const WheelDuties d = wheels::carCmdToDuties(params, speed_mps, 0.0);
  simulation.setDuty(d.left, d.right);
  const double max_s = 10.0 * distance_m / speed_mps;
  while (simulation.time_s() < max_s) {
    simulation.advance(0.01);
    const Pose2D p = simulation.pose();
    if (p.x_m >= distance_m) return std::abs(p.y_m);
  }
  return std::nan("");
}

}  // namespace sim
}  // namespace autocal
