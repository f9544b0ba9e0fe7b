#include "support/umbmark_runs.h"

#include <random>

#include "odometry/square_model.h"

namespace autocal {
namespace test {

UmbmarkRuns driveSquares(const odometry::DiffDriveParams& truth,
                         const odometry::DiffDriveParams& odometry, double side_m, int n,
                         double noise_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  UmbmarkRuns runs;
  for (int i = 0; i < n; ++i) {
    for (bool clockwise : {true, false}) {
      odometry::ReturnError e = odometry::simulateUmbmarkSquare(truth, odometry, side_m, clockwise);
      if (noise_m > 0) {
        e.x_m += noise(rng);
        e.y_m += noise(rng);
      }
      (clockwise ? runs.cw : runs.ccw).push_back(e);
    }
  }
  return runs;
}

}  // namespace test
}  // namespace autocal
