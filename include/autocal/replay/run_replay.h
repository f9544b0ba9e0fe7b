// A recorded calibration run recomputed, ROS-free: the recording's messages, in the order they were
// received, go to the replay Stages (camera::SweepReplay, wheels::WheelReplay) as the live stages'
// nodes got them. Each stage is built when the recording reaches it (its first recorded phase past
// "<stage>/wait"; the camera stage at its first camera_info), follows the recorded commands and
// phases, and is finished at the recorded stage's DONE or FAILED: it writes its file under the
// replay's calibration_root, and the wheel stage takes the replayed camera stage's intrinsics. A
// report::RunRecorder keeps the replay's own statuses for the report. The ROS layer turns a bag
// into these calls (autocal_ros/recording_reader.h); `rosrun autocal replay` runs it with no
// master.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "autocal/camera/sweep_replay.h"
#include "autocal/camera_intrinsics.h"
#include "autocal/report/run_record.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"
#include "autocal/wheels/wheel_replay.h"

namespace autocal {
namespace replay {

struct RunReplayOptions {
  std::string veh;
  std::string calibration_root;  ///< where the replay writes its files
  /// The stages replayed, in run order: "camera", "wheels", "odometry" (any of them).
  std::vector<std::string> stages = {"camera", "wheels"};
  camera::CameraCalibrationConfig camera;  ///< loadStageCameraConfig, as the live node
  camera::SweepRunOptions camera_run;
  bool use_camera_info_guess = true;            ///< the recorded camera_info starts the fit
  camera::CameraInfoFormat camera_info_format;  ///< the intrinsics file's writer
  /// The wheel stage's options; its kinematics are the robot's before the run.
  wheels::WheelRunOptions wheel_run;
  /// The wheel stage's intrinsics (a camera_info YAML file); empty: the replayed camera stage's.
  std::string intrinsics_file;
  /// The odometry stage recomputed from the whole recording (odometry::replayUah on what the
  /// caller read of it) and its file written; called at the recorded odometry stage's end.
  std::function<StageResult(const StageOutput& output)> odometry;
  /// The recording replayed (the report names it).
  std::string recording;
  /// A line for a person: a stage begins, ends or fails.
  std::function<void(const std::string& line)> log;
};

class RunReplay {
 public:
  /// Throws ConfigError on unknown stages, IoError/ConfigError on an unreadable intrinsics_file.
  explicit RunReplay(RunReplayOptions options);
  ~RunReplay();

  /// The stamps of the frames each live stage took, by stage (its node recorded them on
  /// calibration/frames_used): the replay takes the same frames. A stage without: its own rule.
  void setFramesUsed(std::map<std::string, std::set<double>> frames_used) {
    frames_used_ = std::move(frames_used);
  }

  // The recording's messages, in the order they were received.
  /// The robot's camera_info (the first is kept: the frames' size, the camera stage's guess).
  void addCameraInfo(const CameraIntrinsics& nominal);
  /// One wheel's encoder reading (`side` 0 left, 1 right), as its driver published it.
  void addEncoderReading(int side, double stamp_s, std::int32_t ticks, int ticks_per_revolution);
  /// Whether the frame stamped `stamp_s` is to be decoded and given to addFrame.
  bool wantsFrame(double stamp_s) const;
  /// A wanted frame, 8-bit grey; one of another size than the camera's is dropped (counted).
  void addFrame(double stamp_s, const cv::Mat& gray, const std::string& source);
  /// A frame that could not be decoded (counted, as a live node drops it).
  void dropFrame() { ++frames_dropped_; }
  /// The command the recorded robot was given.
  void addCommand(double stamp_s, const WheelDuties& duties);
  /// A status of the recorded run (calibration/status): it builds and ends the stages.
  void addRecordedStatus(const report::StatusUpdate& status);

  /// Every stage ended, or one failed: nothing more of the recording is needed.
  bool ended() const { return recorder_.ended(); }
  /// The recording has no more messages: the stage it did not end fails.
  void endOfRecording();
  /// The recording could not be read (why): the run fails, the stages not ended with it.
  void abort(const std::string& why) { recorder_.markInterrupted(why); }
  /// The stage being replayed and what it has (e.g. "wheels: 8 drives, 17 stills").
  std::string describe() const;
  /// The replay's own statuses, for the report.
  const report::RunRecord& record() const { return recorder_.record(); }

 private:
  const std::string& current() const;
  /// "the wheel stage": the stage's name as a person says it.
  static std::string noun(const std::string& stage);
  void build(double stamp_s);
  void finishStage(double stamp_s);
  void finishOdometry(double stamp_s);
  /// The current stage's DONE with `result`; the next stage becomes current.
  void done(double stamp_s, StageResult result);
  void fail(double stamp_s, const std::string& why);
  void status(double stamp_s, report::StatusUpdate::State state, const std::string& step,
              const std::string& text, const Figures& figures, const std::string& file = "");
  void log(const std::string& line) const;

  RunReplayOptions options_;
  report::RunRecorder recorder_;
  std::size_t current_ = 0;  ///< index into options_.stages
  std::unique_ptr<Stage> stage_;
  wheels::WheelReplay* wheel_ = nullptr;
  bool have_nominal_ = false;
  CameraIntrinsics nominal_;
  cv::Size frame_size_;
  int frames_dropped_ = 0;
  // The latest count of each wheel (the camera stage takes both at every reading, as a node's
  // EncoderInput gives them), and both counts at one instant for the wheel stage.
  std::int32_t ticks_[2] = {0, 0};
  bool have_ticks_[2] = {false, false};
  EncoderPairer pairer_;
  double last_stamp_s_ = 0;
  bool odometry_started_ = false;
  std::map<std::string, std::set<double>> frames_used_;
};

}  // namespace replay
}  // namespace autocal
