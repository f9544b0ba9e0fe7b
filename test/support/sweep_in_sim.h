// The camera stage (camera::SweepRun) driven by the simulator's core directly, no ROS: the run's
// duties go to the physics, encoders and frames come back at the robot's rates and on sim time,
// and a frame is rendered only when the run wants one (a node would drop the others). Shared by
// the accuracy tests and the sweep benchmark; the run never sees the truth, the caller compares.
#pragma once

#include <string>
#include <vector>

#include "autocal/camera/camera_config.h"
#include "autocal/camera/sweep_run.h"
#include "autocal/sim/config.h"
#include "support/stage_in_sim.h"

namespace autocal {
namespace test {

/// The loop's options (no links: frames and readings at once), and a trace.
struct SweepInSimOptions : StageInSimOptions {
  SweepInSimOptions() {
    max_sim_s = 400.0;
    transport = false;
  }
  bool trace = false;  ///< one stderr line per processed frame (boards, decision, state)
};

struct SweepInSim {
  bool swept = false;
  std::string failure;  ///< the run's CalibrationError, if it failed
  double sim_s = 0;     ///< simulated time from start to the end of the sweep
  double wall_s = 0;
  int frames_rendered = 0;
  std::vector<double> frame_ms;      ///< thread CPU time of SweepRun::addFrame per processed frame
  camera::CalibrationResult result;  ///< valid when swept and calibrated
  std::string calibration_failure;   ///< calibrate() threw
  int views = 0, sharp_views = 0, steps = 0;
  camera::MinDutyResult min_duty;
  /// (sim time [s], SweepRun::progress()) at each change of the progress, and at the end.
  std::vector<std::pair<double, double>> progress;
  camera::BoardSpec board;
  camera::CalibrationOptions calibration_options;  ///< what the run calibrated with
  cv::Size image_size;
  std::vector<std::vector<cv::Point2f>> sharp;  ///< every sharp board seen (refined corners)
  /// The same views' corners as the stage calibrates on them (camera::cornersToCalibrate: refined
  /// again through the lens where it does that); empty unless swept.
  std::vector<std::vector<cv::Point2f>> calibrated;
  /// The truth at each frame the stage took: how fast the robot turned over the frame period
  /// before its capture stamp [rad/s].
  std::vector<double> view_yaw_rate_rad_s;
};

/// The shipped camera config as the node uses it with `world`'s boards, starting from what
/// camera_info says (the robot's nominal model); the half-resolution precheck off.
camera::CameraCalibrationConfig cameraConfigFor(const sim::WorldConfig& world,
                                                const sim::RobotConfig& robot);
/// The stage's options as the node sets them from camera_info (the nominal field of view).
camera::SweepRunOptions runOptionsFor(const sim::RobotConfig& robot);

/// Runs the stage in `world` with `robot`; `run` is constructed by the caller (options, board).
SweepInSim runSweepInSim(const sim::RobotConfig& robot, const sim::WorldConfig& world,
                         camera::SweepRun& run, const SweepInSimOptions& options);

}  // namespace test
}  // namespace autocal
