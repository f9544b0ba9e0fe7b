// What a calibration run published, as the report keeps it: every stage's status on the one status
// topic (doc/calibration_run.md), the encoder readings, and (in the simulator) the true poses. A
// RunRecorder is fed them and says when the run has ended (every stage DONE, or one FAILED).
// ROS-free.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "autocal/pose2d.h"
#include "autocal/sensors.h"

namespace autocal {
namespace report {

/// One status message (autocal/CalibrationStatus) as the recorder needs it.
struct StatusUpdate {
  double stamp_s = 0;
  std::string phase;  ///< "<stage>/<step>", e.g. "wheels/iterate"
  enum class State { kIdle, kRunning, kDone, kFailed } state = State::kRunning;
  double progress = -1;
  std::string text, failure_reason;
  std::string file;  ///< the file a DONE stage wrote or kept
  std::vector<std::pair<std::string, double>> figures;
};

enum class StageState { kPending, kRunning, kDone, kFailed };
const char* name(StageState state);  ///< "pending", "running", "done", "failed"

struct StageRecord {
  std::string stage;  ///< "camera", "wheels", "odometry"
  StageState state = StageState::kPending;
  std::string phase;  ///< the last phase seen
  std::string text, failure;
  double progress = -1;
  double start_s = -1, end_s = -1;  ///< stamps of its first and last status
  std::string file;                 ///< the file its DONE carries (written or kept)
  std::vector<std::pair<std::string, double>> figures;  ///< of its last status
  /// The figure `name`, or NaN.
  double figure(const std::string& name) const;
  /// Past waiting for the stage before it (a status other than "<stage>/wait" came).
  bool started() const { return start_s >= 0 || state == StageState::kDone; }
  /// What the report shows: "not started" for a stage that never got past waiting (its node
  /// may have published "<stage>/wait"), otherwise name(state).
  std::string stateText() const;
};

/// One wheel-stage update of k (from the status figures "iteration", "k", "trim",
/// "last_dtheta_rad").
struct WheelIteration {
  int iteration = 0;
  double k = 1, trim = 0, dtheta_rad = 0, stamp_s = 0;
};

struct EncoderSample {
  double stamp_s = 0;
  double left = 0, right = 0;  ///< both wheels' counts at the stamp [ticks]
};

struct RunRecord {
  std::string vehicle;
  std::vector<StageRecord> stages;  ///< in run order
  std::vector<WheelIteration> wheel_iterations;
  std::vector<EncoderSample> encoders;
  /// The simulator's true poses (its world frame), when one published them; empty on a robot.
  std::vector<std::pair<double, Pose2D>> true_poses;
  int ticks_per_revolution = 0;
  /// The recording this run replays (`rosrun autocal replay`); empty for a live run.
  std::string replay_of;
  /// Set by RunRecorder::markStageDead and markInterrupted: why the run ended without its stages'
  /// DONE or FAILED.
  std::string run_failure;

  bool succeeded() const;
  /// The first failure: a stage's reason ("wheels: ...") or run_failure; empty on success.
  std::string failure() const;
  const StageRecord* stage(const std::string& name) const;
};

class RunRecorder {
 public:
  /// `stages`: the stages of the run, in order (e.g. {"camera", "wheels"}). Throws ConfigError
  /// when empty or repeated.
  RunRecorder(const std::string& vehicle, const std::vector<std::string>& stages);

  /// The recording the run replays (RunRecord::replay_of).
  void setReplayOf(const std::string& recording) { record_.replay_of = recording; }
  /// A status of any stage; statuses of stages not in the run (e.g. "sim") are ignored.
  void addStatus(const StatusUpdate& status);
  /// Both wheels' counts at one instant, kept at most every `min_interval_s` for the believed
  /// path.
  void addEncoders(double stamp_s, double left, double right, int ticks_per_revolution,
                   double min_interval_s = 0.05);
  /// One wheel's encoder reading (`side` 0 left, 1 right), as its driver publishes it: paired with
  /// the other wheel's count at the same instant (EncoderPairer) before it is kept.
  void addEncoderReading(int side, double stamp_s, std::int32_t ticks, int ticks_per_revolution,
                         double min_interval_s = 0.05);
  /// The simulator's true pose at `stamp_s`, kept at most every `min_interval_s`: the report draws
  /// the true path beside the believed one. Never given to a stage.
  void addTruePose(double stamp_s, const Pose2D& pose, double min_interval_s = 0.05);
  /// The node of `stage` went away while the stage was running (no DONE or FAILED): the stage
  /// fails with `why`.
  void markStageDead(const std::string& stage, const std::string& why);
  /// The run was stopped from outside before it ended (Ctrl-C; a replay whose recording could
  /// not be played).
  void markInterrupted(const std::string& why);
  /// A resumed run: a stage this run has no status of (still pending) takes the result the last
  /// run's report kept for it, so that a run interrupted before its stages spoke does not lose it.
  void keepFromLastRun(const std::string& stage, const std::string& file,
                       const std::vector<std::pair<std::string, double>>& figures);

  /// Every stage DONE, or one FAILED, or the run marked interrupted.
  bool ended() const;
  /// The stage running now (or the next pending one); empty once ended.
  std::string currentStage() const;
  const RunRecord& record() const { return record_; }

 private:
  StageRecord* find(const std::string& stage);
  RunRecord record_;
  EncoderPairer encoder_pairer_;
};

/// How one stage looks to a person watching the run (run_report_node turns
/// it into a diagnostic_msgs status): OK while pending, running or done; ERROR with the reason
/// when it failed; WARN when it is the stage the run waits on and nothing was heard of it for
/// more than `warn_after_s` [s].
struct StageHealth {
  enum class Level { kOk, kWarn, kError } level = Level::kOk;
  std::string message;
};
/// `current`: the run waits on this stage (RunRecorder::currentStage); `silent_s`: seconds since
/// its last status, or since it became current when that is later; `warn_after_s` <= 0: never
/// WARN.
StageHealth stageHealth(const StageRecord& stage, bool current, double silent_s,
                        double warn_after_s);

}  // namespace report
}  // namespace autocal
