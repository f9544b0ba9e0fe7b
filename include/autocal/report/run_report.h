// The report of one calibration run (doc/calibration_run.md; its files: doc/files.md "The run's
// report"), ROS-free: a RunRecorder is fed what the run published (every stage's status on the one
// status topic, the encoder readings) and says when the run has ended (every stage DONE, or one
// FAILED); the report is then a PNG sheet for a person (the views used and their reprojection
// errors, the image coverage by board corners, the wheel stage's believed path and k per iteration,
// the odometry figures, pass/fail) and summary.yaml with the figures, written atomically beside the
// calibration files. It reads only what the calibration nodes publish and write, never a
// simulator's truth.
#pragma once

#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
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
  /// The recording this run replays (replay.launch); empty for a live run.
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

/// The pose the encoders give, dead-reckoned (odometry::DeadReckoning) with one wheel radius and
/// a baseline [m]: what the robot believes its path was (x forward at the first sample, y left).
struct PathPoint {
  double t_s = 0;
  Pose2D pose;
};
std::vector<PathPoint> believedPath(const RunRecord& record, double wheel_radius_m,
                                    double baseline_m);
/// The simulator's true path in the believed path's frame (x forward, y left at the true pose of
/// the first encoder sample, or the first true pose when that came later); empty without true
/// poses or encoder readings.
std::vector<PathPoint> truePath(const RunRecord& record);

/// One view of the camera stage's audit (camera_intrinsic/<veh>_views/views.yaml).
struct AuditView {
  std::string image;  ///< path of its PNG
  double rms_px = 0;
  std::vector<cv::Point2f> corners;
};
struct ViewsAudit {
  bool loaded = false;
  cv::Size image_size;
  double rms_px = 0;
  std::vector<AuditView> views;
};
/// Reads the audit; throws ConfigError (file and line) on a malformed file, IoError when missing.
ViewsAudit loadViewsAudit(const std::string& views_yaml);

/// Share of the cells of a cols × rows grid over the image that hold a board corner of some view.
double cornerCoverage(const ViewsAudit& audit, int cols = 8, int rows = 6);

struct ReportOptions {
  double wheel_radius_m = 0.0318;  ///< for the believed path (the kinematics file's, when written)
  double baseline_m = 0.1;

  /// Gates the report adds to the stages' own: the camera's RMS reprojection error and its corner
  /// coverage of the image.
  /// (The simulator's default world, boards at one height around the robot, gives about 46 %.)
  double max_camera_rms_px = 1.0;
  double min_corner_coverage = 0.4;
};

struct Gate {
  std::string name;
  bool passed = false;
  std::string detail;
};
/// The believed path with the wheels the run knows best: the odometry stage's per-wheel distances
/// per pulse and wheelbase when it is DONE (its figures left_m_per_pulse, right_m_per_pulse,
/// wheelbase_m), else one radius and baseline from the options. With one radius, wheels of
/// different diameters (Ed ≠ 1) bend every straight drive of the path.
std::vector<PathPoint> believedPath(const RunRecord& record, const ReportOptions& options);

/// Each stage's DONE, and the report's own gates on the figures.
std::vector<Gate> evaluateGates(const RunRecord& record, const ViewsAudit& audit,
                                const ReportOptions& options);

/// The sheet (BGR, 1600 × 1040). `ground_view`: the wheel stage's floor grid over a rectified
/// frame (camera_extrinsic/<veh>_ground.png), or empty.
cv::Mat drawReportSheet(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc,
                        const cv::Mat& ground_view = cv::Mat());
/// summary.yaml's text.
std::string summaryYaml(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc);

/// What a run's summary.yaml says of one stage (for resuming a run after a failure).
struct PreviousStage {
  bool done = false;
  std::string file;
  std::vector<std::pair<std::string, double>> figures;
};
/// Reads `stage` from a summary.yaml that summaryYaml wrote; not done when the file is missing.
/// Throws ConfigError on a malformed file.
PreviousStage previousStage(const std::string& summary_yaml, const std::string& stage);

struct ReportFiles {
  std::string sheet_png, summary_yaml;
};
/// Writes `<dir>/report.png` and `<dir>/summary.yaml`, each atomically (the audit is read from
/// `views_yaml`, the ground view from `ground_png`, each when it exists; a ground view that does
/// not decode is left out). Throws IoError when a file cannot be written.
ReportFiles writeReport(const std::string& dir, const RunRecord& record,
                        const std::string& views_yaml, const ReportOptions& options,
                        const std::string& ground_png = "");

}  // namespace report
}  // namespace autocal
