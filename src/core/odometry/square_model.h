// The exact UMBmark square in the dead-reckoning model, private to the core: the corrected
// expressions invert it (umbmark.cpp), and the test support library drives squares with it.
#pragma once

#include "autocal/odometry/dead_reckoning.h"
#include "autocal/odometry/umbmark.h"

namespace autocal {
namespace odometry {

/// Drives one L×L square in the dead-reckoning model: the controller commands wheel pulses so
/// that its own odometry (`odometry`) completes an exact square, turning on the spot at the
/// corners, while the robot moves with the `truth` parameters. Returns actual − computed end.
ReturnError simulateUmbmarkSquare(const DiffDriveParams& truth, const DiffDriveParams& odometry,
                                  double side_m, bool clockwise);

}  // namespace odometry
}  // namespace autocal
