// The camera stage recomputed from a recording, ROS-free: the passive counterpart of SweepRun. It
// commands nothing; it follows the commands the robot was given (its wheels_cmd) and, in each stop
// of the sweep (paper 000 §3.2: pulse, stop, settle, grab), takes the first frame after the robot
// settled — settle_s after the stop and the encoders still for still_s, and the image seen still
// (SweepRunOptions::stillness), as SweepRun — into the same ViewCollector, then calibrates the
// views exactly as SweepRun does. Only stops while the recorded run was collecting count (the
// min-duty probe's stops do not): the caller says when from the recorded status (setCollecting).
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <utility>

#include "autocal/camera/calibration.h"
#include "autocal/camera/calibration_files.h"
#include "autocal/camera/camera_config.h"
#include "autocal/camera/sweep_run.h"
#include "autocal/camera/view_selection.h"
#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"

namespace autocal {
namespace camera {

class SweepReplay : public Stage {
 public:
  /// Throws ConfigError for invalid options or config.
  SweepReplay(const SweepRunOptions& options, const CameraCalibrationConfig& camera);

  /// The command the robot was given at `stamp_s` (repeats are fine).
  void addCommand(double stamp_s, const WheelDuties& duties);
  /// Cumulative ticks of both wheels (the resolution and the arrival are not used).
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution = 0,
                   double now_s = 0) override;
  /// Whether the recorded run was collecting views from `stamp_s` on (its phase camera/collect).
  /// The start of collecting counts as a stop (SweepRun settles before its first frame).
  void setCollecting(double stamp_s, bool collecting);
  bool collecting() const { return collecting_; }
  /// The first frame after the robot settled in a stop while collecting; with setFramesUsed, the
  /// frames the live stage took while collecting.
  bool wantsFrame(double stamp_s) const override;
  /// The stamps of the frames the live stage took (its node records them): the replay takes the
  /// same frames rather than judging by its own rule where a loaded live node skipped one.
  void setFramesUsed(std::set<double> stamps_s) { frames_used_ = std::move(stamps_s); }
  /// Processes a wanted frame (8-bit grey or colour, one size); false when it was not wanted, or
  /// (without setFramesUsed) only compared with the next frame.
  bool addFrame(double stamp_s, const cv::Mat& image, const std::string& source) override;
  /// Stage input: addCommand, and setCollecting while the phase is camera/collect or camera/refine
  /// (more views after the sweep).
  void addRecordedCommand(double stamp_s, const WheelDuties& duties) override {
    addCommand(stamp_s, duties);
  }
  void addRecordedPhase(double stamp_s, const std::string& phase) override {
    setCollecting(stamp_s, phase == "camera/collect" || phase == "camera/refine");
  }
  /// Commands nothing; never done by itself (the recorded stage's end ends it).
  WheelDuties update(double /*now_s*/) override { return {}; }
  bool done() const override { return false; }
  /// Step "replay": stops and views.
  StageStatus status() const override;
  std::string finishStep() const override { return "calibrate"; }
  void setCameraInfoFormat(CameraInfoFormat format) { camera_info_format_ = std::move(format); }
  /// Calibrates (calibrate()) and writes the intrinsics file with its audit folder as SweepRun
  /// does; needs setCameraInfoFormat.
  StageResult finish(const StageOutput& output) override;

  /// Calibrates and gates the views (calibrateSweepViews); throws CalibrationError.
  CalibrationResult calibrate() const { return calibrateSweepViews(collector_, camera_); }
  const CameraCalibrationConfig& cameraConfig() const { return camera_; }
  const ViewCollector& collector() const { return collector_; }
  const std::vector<CalibrationView>& calibrationViews() const {
    return collector_.calibrationViews();
  }
  /// Grey frames by CalibrationView::frame_index, for the audit folder.
  const std::map<int, cv::Mat>& frames() const { return frames_; }
  int stops() const { return stops_; }
  int framesProcessed() const { return collector_.frames(); }
  /// Sim (recording) seconds from the first to the last frame processed.
  double elapsedS() const { return frames_seen_ ? last_frame_s_ - first_frame_s_ : 0.0; }
  std::string describe() const;

 private:
  SweepRunOptions options_;
  std::set<double> frames_used_;
  CameraCalibrationConfig camera_;
  CameraInfoFormat camera_info_format_;
  ViewCollector collector_;
  bool collecting_ = false;
  bool moving_ = false;
  bool taken_ = true;  ///< the current stop's frame was taken (nothing to take before a stop)
  ImageStillness stillness_;      ///< the current stop's frames
  double first_settled_s_ = -1;  ///< the current stop's first settled frame (-1: none yet)
  void newStop(double stamp_s);
  double stop_s_ = 0;
  int stops_ = 0;
  EncoderTracker encoders_;
  std::map<int, cv::Mat> frames_;
  bool frames_seen_ = false;
  double first_frame_s_ = 0, last_frame_s_ = 0;
};

}  // namespace camera
}  // namespace autocal
