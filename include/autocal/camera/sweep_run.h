// The camera stage of the self-calibration, ROS-free (paper 000 §3.1–3.2): find the minimum moving
// duty of each wheel, then turn one wheel at a time in steps past the boards — a duty pulse, stop,
// wait until the wheels are still and the image has settled, grab one frame, detect, keep the
// views worth keeping, let the SweepController choose the next step — and finally calibrate the
// kept views (Zhang's method through OpenCV) and apply the quality gate.
//
// The node feeds it time, encoder readings and frames and commands the duties update() returns;
// everything here runs on the stamps it is given (sim time in the simulator), so it is tested
// without a master. Failures are thrown as CalibrationError (sweep, camera or encoders silent,
// quality gate) and InputError (bad frames the caller must not pass: see addFrame).
#pragma once

#include <array>
#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autocal/camera/calibration.h"
#include "autocal/camera/calibration_files.h"
#include "autocal/camera/camera_config.h"
#include "autocal/camera/image_stillness.h"
#include "autocal/camera/min_duty_probe.h"
#include "autocal/camera/sweep_controller.h"
#include "autocal/camera/view_selection.h"
#include "autocal/camera/view_targets.h"
#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"

namespace autocal {
namespace camera {

struct SweepRunOptions {
  SweepOptions sweep;
  MinDutyProbeOptions probe;
  /// Measure the minimum moving duty of each wheel and direction before the sweep (paper §3.2);
  /// false: use `min_duty` for all four.
  bool probe_min_duty = true;
  double min_duty = 0.1;
  /// Heading change one step should make [rad]: the pulse's duty above the wheel's minimum is
  /// adapted after every step toward it (0 = always minimum + SweepOptions::step_duty_margin, the
  /// paper's slowest stepping). About 1/15 of the field of view keeps consecutive frames
  /// overlapping while a pass over five boards takes ~40 steps.
  double target_step_rad = 0.1;
  /// Highest duty a step may use [1].
  double max_step_duty = 0.5;
  /// Nominal wheel radius and wheelbase (Duckietown defaults): only turn encoder ticks into a
  /// heading change for the controller, which tolerates their error [m].
  double nominal_wheel_radius_m = 0.0318;
  double nominal_wheelbase_m = 0.1;
  /// The wheels count as still when no encoder changed for this long [s].
  double still_s = 0.1;
  /// Beyond the paper: once the encoders say the robot settled, its view is the first frame whose
  /// image moved no faster than stillness.max_speed_px_s since the frame before (a wheel coasting
  /// to rest turns less than a tick long before it stands); max_still_wait_s after settling, the
  /// next frame is taken whatever the image says, and counted (status figure
  /// views_not_seen_still). stillness.max_speed_px_s 0: the first settled frame, as the paper.
  ImageStillnessOptions stillness;
  double max_still_wait_s = 0.5;
  /// No frame (encoder reading) for this long while running is a failure [s].
  double camera_timeout_s = 5.0;
  double encoder_timeout_s = 2.0;
  /// The whole stage may take this long (probe + sweep) [s]; then it fails.
  double max_duration_s = 600.0;
  /// Coverage goal of the sweep, replacing the camera config's view_selection goal_spread (x, y,
  /// size, skew, distance, tilt spreads, normalised as in ViewParams). A hand-held board can be
  /// moved anywhere; boards standing in a semicircle at one height, seen by a robot that only
  /// turns, span the image's width, tilt and skew but little height, size or distance, so ROS's
  /// goals (y 0.7, size 0.4) are out of reach. Negative: keep the config's goal.
  std::array<double, 6> coverage_goal{{0.6, 0.05, 0.08, 0.2, 0.1, 0.25}};
  /// Views the sweep must keep before its coverage counts (with coverage_goal).
  int min_views = 15;
  /// Calibrate on every sharp board seen instead of only the views the collector kept for their
  /// novelty (ViewSelectionOptions::keep_sharp_views). Novelty decides when the sweep has seen
  /// enough; the fit gains from every sharp view (a robot that stops for each frame sees 30–50 at
  /// no cost).
  bool calibrate_on_sharp_views = true;
  /// When the sweep's views fail the quality gate: rounds of more views where the projection is
  /// least sure (view_targets.h: the worst cell of each half of the image, and the heading that
  /// brings a corner seen there) before the stage fails; 0: it fails at once. Each round takes
  /// a view at each target's heading and refine_spread_rad either side of it, and is judged again.
  int refine_rounds = 2;
  double refine_spread_rad = 0.08;
  /// A target heading counts as reached within this [rad], or when a step crossed it.
  double refine_tolerance_rad = 0.04;
  /// Steps toward one heading before its view is taken where the robot stands.
  int refine_max_steps = 30;
  /// The rounds together may take this long [s] of turning and taking views (within
  /// max_duration_s); the fits that judge them do not count.
  double refine_max_s = 120.0;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// The camera config a sweep collects and calibrates with: `camera` with the options' coverage
/// goal, views count and keep_sharp_views. Throws ConfigError.
CameraCalibrationConfig sweepCameraConfig(CameraCalibrationConfig camera,
                                          const SweepRunOptions& options);

/// The views' corners to calibrate on: with ChessboardDetectorOptions::refine_through_lens, each
/// view that kept its board's pixels refined again through the lens a first fit of all of them
/// finds (of the config's listed models, the one with the lowest all_corners_rms_px, fitted
/// without the whole-image judgement), unless that one is equidistant; else as detected. Throws
/// CalibrationError when the views cannot determine the first model's fit.
std::vector<std::vector<cv::Point2f>> cornersToCalibrate(const std::vector<CalibrationView>& views,
                                                         const cv::Size& image_size,
                                                         const CameraCalibrationConfig& camera);

/// Calibrates the collector's calibrationViews() (Zhang's method through OpenCV; their corners
/// from cornersToCalibrate) with each lens model and applies the config's quality gate
/// (calibrateChoosingModel); throws CalibrationError when there is no view or the views cannot
/// determine a model.
ModelChoice chooseSweepModel(const ViewCollector& collector, const CameraCalibrationConfig& camera);
/// The chosen model's result; throws CalibrationError naming the gates it fails (`after`, if not
/// empty, follows "the result fails the quality gate").
CalibrationResult passedOrThrow(ModelChoice choice, const std::string& after = "");
/// passedOrThrow(chooseSweepModel(collector, camera)).
CalibrationResult calibrateSweepViews(const ViewCollector& collector,
                                      const CameraCalibrationConfig& camera);

/// The robot's nominal camera (its camera_info) in the stage's setup: the sweep's field of view,
/// and with `as_guess` the fit's starting camera matrix.
void useNominalCamera(const CameraIntrinsics& nominal, bool as_guess,
                      CameraCalibrationConfig& camera, SweepRunOptions& run);

/// kJudge: the views are calibrated and judged (the next update after the sweep or a round of
/// more views ends, so that the status says so while it computes).
enum class SweepRunStage { kWaitForData, kProbe, kSweep, kRefine, kJudge, kSwept, kFailed };
/// "wait", "probe", "collect", "refine", "calibrate" (kJudge and kSwept), "failed"
const char* name(SweepRunStage stage);

/// What the last processed frame showed (for the debug image and the status).
struct SweepFrameReport {
  double stamp_s = 0;
  FrameResult frame;
  SweepDecision decision;
};

class SweepRun : public Stage {
 public:
  /// Throws ConfigError for invalid options or config.
  SweepRun(const SweepRunOptions& options, const CameraCalibrationConfig& camera);

  /// Cumulative encoder ticks of both wheels (each may come in its own message: pass the latest of
  /// the other), received at `now_s` (for the encoder timeout). `stamp_s` orders the readings; a
  /// reading older than the last is ignored.
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution,
                   double now_s) override;
  /// A frame is wanted only while the robot stands settled after a step (and once at the start):
  /// check before decoding one.
  bool wantsFrame(double stamp_s) const override;
  /// Noted for the camera timeout even when not wanted (no decoding needed).
  void noteFrameArrived(double now_s) override;
  /// Noted for the encoder timeout (addEncoders notes it too). A node that handles a batch of
  /// messages calls both after the batch: a frame processed last in it may take long, and a
  /// reading handled before it would look older than it is.
  void noteEncodersArrived(double now_s) override;
  /// Processes a wanted frame (8-bit grey or colour, the size of the first frame: the caller
  /// drops others). Returns true when it was taken as the stop's view; false when it was not
  /// wanted, or only compared with the next frame (SweepRunOptions::stillness).
  bool addFrame(double stamp_s, const cv::Mat& image, const std::string& source) override;
  /// Advances the state at time `now_s` and returns the duties to command now. Throws
  /// CalibrationError when the stage fails (the reason names what went wrong).
  WheelDuties update(double now_s) override;

  SweepRunStage stage() const { return stage_; }
  /// The sweep is over with enough views: calibrate() may be called.
  bool swept() const { return stage_ == SweepRunStage::kSwept; }
  bool done() const override { return swept(); }
  /// Calibrates the kept views and applies the quality gate; throws CalibrationError when the views
  /// cannot determine the model or the result fails the gate. After the sweep the stage has
  /// judged its views already (see refine_rounds): this is the result it judged.
  CalibrationResult calibrate() const;
  /// Rounds of more views made where the projection was least sure, and the targets of the last.
  int refineRounds() const { return refine_round_; }
  const std::vector<ViewTarget>& refineTargets() const { return targets_; }
  /// Why the sweep's own views were refused (empty: they passed, or not judged yet).
  const std::string& sweepRefusal() const { return sweep_refusal_; }
  /// The calibration views when the sweep's views were refused (0: they were not).
  int sweepViews() const { return refine_views_before_; }
  /// The heading by the encoders (nominal wheels) since the sweep began [rad, + = ccw].
  double headingRad() const { return heading_rad_; }

  const SweepController& controller() const { return controller_; }
  /// The camera config in use (the sweep's coverage goal and views count applied).
  const CameraCalibrationConfig& cameraConfig() const { return camera_; }
  const ViewCollector& collector() const { return collector_; }
  const MinDutyProbe& probe() const { return probe_; }
  /// Minimum moving duty per wheel and direction (measured, or the configured one).
  MinDutyResult minDuty() const;
  /// Every sharp board seen (refined corners; empty unless calibrate_on_sharp_views).
  const std::vector<CalibrationView>& sharpViews() const { return collector_.sharpViews(); }
  /// The views calibrate() fits (sharpViews() or the collector's kept views, by
  /// calibrate_on_sharp_views): CalibrationResult::used_views indexes them.
  const std::vector<CalibrationView>& calibrationViews() const;
  /// Grey frames by CalibrationView::frame_index, for the audit folder.
  const std::map<int, cv::Mat>& frames() const { return frames_; }
  const SweepFrameReport& lastFrame() const { return last_frame_; }
  /// Views taken max_still_wait_s after settling without the image seen still.
  int viewsNotSeenStill() const { return views_not_seen_still_; }
  /// Seconds since the stage started (0 before), steps made, frames processed.
  double elapsedS() const { return started_ ? last_now_s_ - start_s_ : 0.0; }
  int framesProcessed() const { return collector_.frames(); }
  /// Progress of the stage, 0..1 (probe ~0.05, sweep by coverage and passes).
  double progress() const;
  /// One line for the status, e.g. "probe: left forward at duty 0.09" or the controller's line.
  std::string describe() const;
  /// Step: the stage (probe, collect, ...).
  StageStatus status() const override;
  std::string finishStep() const override { return "calibrate"; }

  /// How the intrinsics file is formatted (calibration_files.h).
  void setCameraInfoFormat(CameraInfoFormat format) { camera_info_format_ = std::move(format); }
  /// Calibrates (calibrate()) and writes <calibration_root>/camera_intrinsic/<veh>.yaml with its
  /// audit folder; needs setCameraInfoFormat.
  StageResult finish(const StageOutput& output) override;
  /// The result finish() wrote (valid after it).
  const CalibrationResult& calibration() const { return calibration_; }

 private:
  enum class Step { kPulse, kSettle };
  void startPulse(double now_s, const WheelDuties& duties, double length_s);
  bool settled(double now_s) const;
  double headingChangeSinceObservation();
  /// The sweep or a round of more views ended: calibrate, and either pass, plan the next round,
  /// or fail.
  void judgeViews();
  WheelDuties refineStep(double now_s);
  /// Fails when no usable frame came for camera_timeout_s since the robot settled.
  void failWithoutUsableFrame(double now_s);
  [[noreturn]] void fail(const std::string& reason);

  SweepRunOptions options_;
  CameraCalibrationConfig camera_;
  CameraInfoFormat camera_info_format_;
  CalibrationResult calibration_;
  SweepController controller_;
  /// Progress through the sweep's legs: the current leg (SweepController::pass), the heading it
  /// began at and the widest leg so far [rad]; the sweep usually ends in its third leg.
  static constexpr double kExpectedLegs = 3;
  static constexpr double kFirstLegArcRad = M_PI;  ///< before a leg ended: half a turn
  /// Of the stage's progress: the probe takes 16-17 s of a 23-40 s stage in the default world.
  static constexpr double kProbeShare = 0.5;
  int leg_ = 0;
  double leg_start_rad_ = 0, leg_arc_rad_ = 0;
  MinDutyProbe probe_;
  ViewCollector collector_;
  SweepRunStage stage_ = SweepRunStage::kWaitForData;
  Step step_ = Step::kSettle;
  WheelDuties duties_;
  double duty_above_min_ = 0;
  bool last_was_turn_ = false;
  bool probe_pulsed_ = false;
  bool pending_decision_ = false;  ///< a frame was processed; update() acts on its decision
  double settled_at_s_ = -1;       ///< when the robot was found settled (-1: not yet)
  ImageStillness stillness_;       ///< the frames since settled_at_s_
  int views_not_seen_still_ = 0;   ///< taken after max_still_wait_s without a still image
  /// Settled at `now_s` (or again, for a refine grab): the view is the next still frame.
  void settleAt(double now_s);
  /// Updates in a row without a frame (encoder reading); a timeout needs more than this many.
  static constexpr int kSilentUpdates = 10;
  int updates_without_frames_ = 0, updates_without_encoders_ = 0;
  bool have_first_update_ = false;
  double first_update_s_ = 0;

  bool started_ = false;
  double start_s_ = 0, last_now_s_ = 0;
  double pulse_end_s_ = 0, stop_s_ = 0;
  EncoderTracker encoders_;
  double encoder_arrival_s_ = 0;
  int ticks_per_rev_ = 0;
  int probe_start_left_ = 0, probe_start_right_ = 0;
  int obs_left_ = 0, obs_right_ = 0;  ///< ticks at the last observation
  bool have_frame_ = false;
  double frame_arrival_s_ = 0;
  bool first_observation_ = true;
  std::map<int, cv::Mat> frames_;
  SweepFrameReport last_frame_;

  double heading_rad_ = 0;               ///< see headingRad()
  std::map<int, double> frame_heading_;  ///< heading_rad_ at each frame processed, by index
  std::optional<ModelChoice> choice_;    ///< the last judgement of the views
  std::string sweep_refusal_;
  int refine_round_ = 0;
  double refine_spent_s_ = 0;        ///< in the finished rounds, turning and taking views
  double refine_round_start_s_ = -1;  ///< the current round's first step
  std::vector<ViewTarget> targets_;
  std::vector<double> refine_headings_;  ///< of the current round, in the order visited
  size_t refine_next_ = 0;
  int refine_steps_ = 0;       ///< toward the current heading
  double refine_last_remaining_ = 0;
  bool refine_grab_ = false;   ///< at the current heading: its frame is wanted
  int refine_views_before_ = 0;
};

}  // namespace camera
}  // namespace autocal
