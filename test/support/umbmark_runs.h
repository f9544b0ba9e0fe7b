// Test scaffolding for UMBmark: return errors of squares driven in the dead-reckoning model,
// with seeded Gaussian noise standing for the non-systematic errors.
#pragma once

#include <vector>

#include "autocal/odometry/umbmark.h"

namespace autocal {
namespace test {

struct UmbmarkRuns {
  std::vector<odometry::ReturnError> cw, ccw;
};

/// n squares each way: the robot moves with `truth`, odometry counts with `odometry`; noise
/// [m] is added to each return point (seeded).
UmbmarkRuns driveSquares(const odometry::DiffDriveParams& truth,
                         const odometry::DiffDriveParams& odometry, double side_m, int n,
                         double noise_m, unsigned seed);

}  // namespace test
}  // namespace autocal
