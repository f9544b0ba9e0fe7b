// The simulator's truth about a robot's view of the floor, for judging ground projections (tests
// and compare_extrinsics; never a calibration): the camera_info a calibration of the true lens
// writes, and how far a homography puts floor points from where the simulator's own camera mount
// (sim::cameraToRobotRotation, not the core's) sees them.
#pragma once

#include <string>

#include "autocal/extrinsics/floor_board.h"
#include "autocal/sim/config.h"

namespace autocal {
namespace sim {

/// The true lens with P from OpenCV's optimal new camera matrix at alpha 0 (as the camera stage
/// writes it) and R the identity.
extrinsics::CameraInfoRectification trueCameraInfo(const sim::RobotConfig& robot);

/// That camera_info as a ROS camera_info YAML file's text.
std::string cameraInfoYaml(const extrinsics::CameraInfoRectification& camera);

/// The true rectified pixel of a floor point (robot frame); false when it is behind the camera or
/// outside the image.
bool trueFloorPixel(const sim::RobotConfig& robot, const extrinsics::RectifiedCamera& camera,
                    const Eigen::Vector2d& ground_m, Eigen::Vector2d* pixel);

struct FloorError {
  double rms_m = 0, max_m = 0;
  int points = 0;
};

/// Floor points every 2 cm from 0.1 m to 0.6 m ahead of the axle that the camera sees, each at its
/// true rectified pixel, projected with H and compared with where they are.
FloorError floorError(const sim::RobotConfig& robot, const extrinsics::RectifiedCamera& camera,
                      const Eigen::Matrix3d& H);

/// The same for a calibration: each floor point's true raw pixel (the true lens) is rectified with
/// the calibrated camera_info (as Duckietown rectifies a frame), projected with H, and compared
/// with where the point is. Points the true lens does not image are left out.
FloorError floorErrorThroughCalibration(const sim::RobotConfig& robot,
                                        const extrinsics::CameraInfoRectification& calibrated,
                                        const Eigen::Matrix3d& H);

/// "floor E mm RMS, M mm worst; height H mm (truth T), pitch ... deg (...), roll, yaw, x, y": a
/// mount found against the robot's true one, for a test's or a tool's printout.
std::string mountVersusTruth(const FloorError& floor, const extrinsics::CameraMount& found,
                             const CameraConfig& truth);

}  // namespace sim
}  // namespace autocal
