// Four camera mounts of the default robot for the extrinsics tests, each with every degree of
// freedom a real mount has (height, pitch, roll, yaw, offsets); the last also sees through a
// shorter lens.
#pragma once

#include "autocal/sim/config.h"

namespace autocal {
namespace test {

constexpr int kCameraMounts = 4;

/// Puts mount `i` (0 .. kCameraMounts − 1; 0 leaves the config's own) on `robot`'s camera.
inline void setCameraMount(sim::RobotConfig& robot, int i) {
  sim::CameraConfig& c = robot.camera;
  switch (i) {
    case 0:
      break;
    case 1:
      c.height_m = 0.095, c.pitch_rad = 0.33, c.roll_rad = 0.02, c.yaw_rad = 0.03, c.x_m = 0.065,
      c.y_m = 0.008;
      break;
    case 2:
      c.height_m = 0.118, c.pitch_rad = 0.21, c.roll_rad = -0.025, c.yaw_rad = -0.04, c.x_m = 0.048,
      c.y_m = -0.012;
      break;
    default:
      c.height_m = 0.105, c.pitch_rad = 0.28, c.roll_rad = 0.015, c.yaw_rad = -0.02, c.x_m = 0.06;
      c.truth.fx *= 0.92;
      c.truth.fy *= 0.92;
  }
}

}  // namespace test
}  // namespace autocal
