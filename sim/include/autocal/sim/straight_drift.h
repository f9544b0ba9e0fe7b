// Duckietown's acceptance test of a wheel calibration, on the simulator's truth (a validation of a
// calibration; no calibration reads it). No ROS.
#pragma once

#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"

namespace autocal {
namespace sim {

/// From rest at the origin facing +x on an empty floor, command car_cmd (v, 0) through the
/// kinematics `params` until the robot has come `distance_m` along x; the lateral drift |y| [m]
/// (NaN when it never gets there). The systematic drift, the one a calibration can remove: the
/// robot's random wheel slip (wheel_slip_sigma) is left out, since one seed's slip walks the
/// robot about 1 cm aside over 2 m whatever the calibration.
double straightDriftM(const RobotConfig& robot, const wheels::KinematicsParams& params,
                      double speed_mps, double distance_m = 2.0);

}  // namespace sim
}  // namespace autocal
