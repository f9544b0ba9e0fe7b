// The one planar pose type of autocal: the robot on the floor (odometry, the simulator's world,
// the wheel stage), x and y [m] and the heading yaw [rad] counter-clockwise from x.
#pragma once

namespace autocal {

struct Pose2D {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

}  // namespace autocal
