// The wheel stage of the self-calibration, ROS-free (paper 000 §3.3, §3.4, §5.1):
//   align    turn one wheel at a time in steps until a floor tag is in view and the robot's heading
//            relative to the tags is near zero (§3.3);
//   iterate  drive forward for a fixed time at the current trim, measure the heading change from
//            the tags, update the trim (TrimEstimator, §3.4), drive back the same time; repeat
//            until three updates in a row are ignored;
//   leave    re-align, drive straight until no tag has been in view for a while, drive on a given
//            distance, stop (§5.1).
// Beyond the paper, the deadband: the drives alternate between two speeds and each wheel's
// steady encoder rate against its duty gives the duty at which it starts to turn (a line fit per
// wheel); with that offset compensated the wheel speed is proportional to the command, and the
// trim that converges at both speeds is right at every speed.
//
// The node feeds it time, encoder readings and frames and commands the duties update() returns;
// it runs on the stamps it is given (sim time in the simulator), so it is tested without a master.
// Failures are thrown as CalibrationError.
#pragma once

#include <array>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/extrinsics/tag_mount.h"
#include "autocal/markers/tag_detector.h"
#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"
#include "autocal/wheels/kinematics.h"
#include "autocal/wheels/motor_fit.h"
#include "autocal/wheels/tag_heading.h"
#include "autocal/wheels/trim_estimator.h"

namespace autocal {
namespace wheels {

/// A wheel-stage stop has settled after this long at the latest, whatever the encoders say [s]
/// (WheelRun and its replay).
constexpr double kMaxSettleS = 2.0;

struct WheelRunOptions {
  markers::TagDetectorOptions detector;
  HeadingOptions heading;
  CameraMount mount;
  TrimEstimatorOptions trim;
  /// The robot's kinematics before the calibration (file or defaults): gain, radius, baseline, k,
  /// limit are kept; trim is replaced; deadband_left/right are the first guess of the offsets
  /// (e.g. the camera stage's minimum moving duties) and are replaced when compensating.
  KinematicsParams kinematics;
  /// The camera_info file the intrinsics came from: the extrinsics file's rectified camera (its
  /// projection matrix) and provenance. Needed by finish() when extrinsics_spins > 0.
  std::string intrinsics_file;

  /// Search tags only in the image rows that can show floor within heading.max_distance_m plus a
  /// tag (detector.min_row_px, unless set): farther tags are not used, and detection is faster.
  bool crop_to_floor = true;
  /// Fit and compensate each wheel's deadband (written as deadband_left/right); false: Duckietown's
  /// semantics exactly (offsets 0), the trim is then right at the first drive speed only.
  bool compensate_deadband = true;
  /// Speed of the forward drives that measure the trim [m/s] (the calibration speed).
  double drive_speed_mps = 0.25;
  /// Speed of every other drive back over the same distance [m/s] (the first one included; the
  /// others at drive_speed_mps): with compensate_deadband another speed, so that each wheel's duty
  /// → speed line has two duties in each direction's drives (else the drive speed).
  double back_speed_mps = 0.4;
  /// Beyond the paper: a drive back retraces the forward drive by the encoders. Each wheel's duty
  /// above its offset is corrected (PI, opposite ways) so that the wheels' angles keep the forward
  /// drive's ratio, closing a deviation in about back_steer_s [s] (0: not steered, the duties the
  /// kinematics give). A motor a few per cent stronger backward than forward, before the motor fit
  /// tells the directions apart, otherwise turns the robot by tens of degrees over a drive back,
  /// off the tag line. A steered drive enters the motor fit once its duties have settled
  /// (max_duty_trend); should the trim converge before the fit has a line for each wheel, the
  /// stage drives on for it (max_fit_cycles).
  double back_steer_s = 0.5;
  /// The largest correction: a share of each wheel's duty above its offset [1].
  double max_back_steer = 0.25;
  /// With compensate_deadband, when the trim converges before the motor fit has a line for each
  /// wheel, up to this many more drives forward and back for the fit alone; then FAILED rather
  /// than the deadband guesses written as the robot's.
  int max_fit_cycles = 4;
  /// Length of one drive (paper §3.4: fixed time) [s], once the trim is close. An uncalibrated
  /// robot one wheel 20 % stronger would turn by a radian over such a drive and lose the tags, so a
  /// drive is shortened (not below min_drive_s) to turn by at most max_drive_turn_rad for the ratio
  /// error still expected: initial_ratio_error before the first drive, half the last update after
  /// it.
  double drive_s = 4.0;
  double min_drive_s = 0.5;
  double max_drive_turn_rad = 0.25;
  double initial_ratio_error = 0.25;
  /// The start of a drive that the motor fit skips (the wheels' lag) [s].
  double motor_settle_s = 0.3;
  /// Only drives whose steady part lasts this long enter the motor fit [s].
  double min_fit_window_s = 0.8;
  /// Drives (forward and back alternate; every other drive back at the other speed) whose rates
  /// make the fit; later drives leave it as it is, so that the trim converges against fixed
  /// offsets. Eight: each direction's line spans two duties after four drives back.
  int fit_drives = 12;
  /// A drive whose steady rate is off the other drives' line by more than this share is left out
  /// of the fit (a bump, a slipping wheel) [1].
  double max_fit_residual = 0.015;

  /// |heading| below which the robot counts as aligned with the tags [rad]. After a turning step
  /// that overshot (the heading changed sign), half that step, at most twice this: the smallest
  /// step a robot with static friction and late commands makes can exceed the window.
  double align_tolerance_rad = 0.035;
  /// Before a drive, |heading| above this makes the robot re-align first [rad].
  double realign_above_rad = 0.15;
  /// Turning steps: the driving wheel's duty above its offset [1]; a step ends when the encoder
  /// shows the step's turn, or after max_pulse_s [s] (a wheel that did not move raises the duty).
  double turn_duty_margin = 0.06;
  double max_pulse_s = 1.0;
  /// While no tag is in view, each step turns about this much [rad] (well below the field of view,
  /// so no tag is stepped over); once one is, 0.8 of the heading.
  double search_step_rad = 0.25;
  /// Turning without seeing a tag for more than this fails ("no tag in a full turn") [rad].
  double max_search_turn_rad = 7.0;
  /// Turning steps in one alignment before it fails.
  int max_align_steps = 80;

  /// Wait after a stop until the encoders have been still this long [s] and at least settle_s.
  double still_s = 0.1;
  double settle_s = 0.3;
  /// Frames whose tags make one heading measurement.
  int heading_frames = 8;
  /// A measurement that sees no tag in this many frames gives up (re-align, or fail) [frames].
  int max_frames_without_tags = 4;

  /// Leaving: speed [m/s]; no tag in view for this long means out of the tag field [s]; then drive
  /// on this far [m] (the camera does not see the floor just ahead of the robot); fail when still
  /// seeing tags after max_leave_m [m].
  double leave_speed_mps = 0.2;
  double leave_clear_s = 0.5;
  int leave_clear_frames = 10;
  double exit_extra_m = 0.3;
  double max_leave_m = 3.0;
  /// Leaving, beyond the paper: steered onto the tag line while tags are in view. The drives and
  /// the mount's hops leave the robot beside the line (up to 0.2 m in robot mode), and a robot
  /// that leaves from there ends the stage beside the free line the next stage starts on. The
  /// target heading is −leave_lateral_gain_rad_per_m · the lateral offset, at most
  /// leave_max_correction_rad, approached at leave_heading_gain_per_s; a frame older than
  /// leave_steer_max_age_s (by its stamp) steers no more. Both gains 0: the paper's straight
  /// leave.
  double leave_lateral_gain_rad_per_m = 3.0;
  double leave_max_correction_rad = 0.25;
  double leave_heading_gain_per_s = 2.0;
  double leave_steer_max_age_s = 0.5;

  /// The camera's mount from the floor tags (extrinsics::mountFromTags): after the trim converged
  /// and before leaving, turn on the spot this many times between stills (by extrinsics_spin_rad
  /// towards the side the tags are on and back, alternately), align with the tag line again
  /// (the turns' errors add up to degrees, and hops that run off the line lose their tags), then
  /// drive extrinsics_drives hops of extrinsics_drive_m straight forward (short enough that a tag
  /// stays in view) and extrinsics_drives_back back, and fit the mount to the tags of every still
  /// of the stage (the hops forward but the first of each pass, extrinsics_passes, give the yaw,
  /// the turns the camera's place).
  /// The hops back give only their stills: a robot's wheels differ backward, and hops back curve
  /// (by 1-6 deg each on the robustness draws); the robot leaves forward from where the hops end.
  /// 0 spins: no extrinsics.
  int extrinsics_spins = 0;
  double extrinsics_spin_rad = 0.3;
  double extrinsics_drive_m = 0.12;
  int extrinsics_drives = 8;
  int extrinsics_drives_back = 0;
  /// Passes of those hops: after each but the last the robot drives back to half a hop behind
  /// where the pass's hops began (by the encoders), aligns with the tag line again and hops
  /// anew, its first hop again not counted. Each hop's yaw carries an error its stills' views of
  /// their tags keep (where in the image, how far) and the turn the wheels' slip gave it; a
  /// pass whose stills see the tags at other places narrows the hops' mean (with one pass of 7
  /// counted hops their yaws spread 0.3-0.6 deg on robot-mode runs).
  int extrinsics_passes = 2;
  /// When the mount after extrinsics_passes passes is refused (too few hops or stills, or a
  /// standard deviation over its limit below), the robot hops another pass, and so on up to this
  /// many passes in all, before it gives the mount up; the refusal then names the passes. Each
  /// pass adds its counted hops to the yaw's mean: on robot-mode runs at real-time factor 3, 2 of
  /// 20 drawn robots had their mount refused after two passes with the yaw's standard deviation
  /// just over its limit (0.259-0.271 deg for 0.252). 1..5; at most extrinsics_passes: none
  /// added.
  int extrinsics_max_passes = 4;
  /// Hops forward (but the first) with a tag seen before and after that the yaw needs; fewer and
  /// the mount is refused. With hops, the yaw comes from these alone
  /// (TagMountOptions::straight_only); without (extrinsics_drive_m 0), from the iteration's drives.
  int extrinsics_min_hops = 3;
  /// The mount is refused (no extrinsics, the stage goes on) when one standard deviation of it
  /// (the jackknife over the stills) moves a floor point 0.5 m ahead by more than this [m]
  /// (extrinsics::floorSigmaM), or when too few stills give no standard deviation.
  double extrinsics_max_floor_sigma_m = 0.005;
  /// The mount is also refused when one standard deviation of its yaw is over this [rad]: half
  /// the 0.5 deg a ground projection may be turned, so that the yaw written is within it at two
  /// (a robot-mode run wrote a yaw 0.67 deg off with 0.41 deg of standard deviation, its floor
  /// point 4 mm).
  double extrinsics_max_yaw_sigma_rad = 0.0044;
  extrinsics::TagMountOptions extrinsics;

  double camera_timeout_s = 5.0;
  double encoder_timeout_s = 2.0;
  double max_duration_s = 600.0;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

enum class WheelRunStage { kWaitForData, kAlign, kIterate, kExtrinsics, kLeave, kDone, kFailed };
/// "wait", "align", "iterate", "extrinsics", "leave", "done", "failed"
const char* name(WheelRunStage stage);

/// The stage's tag detector: the options' detector, searching only the rows that can show floor
/// within reach (crop_to_floor), with the floor's normal from the mount.
std::unique_ptr<markers::TagDetector> makeFloorTagDetector(const WheelRunOptions& options,
                                                           const CameraIntrinsics& intrinsics);

/// The motor fit's options from the run's.
MotorFitOptions motorFitOptions(const WheelRunOptions& options);

/// The wheel stage's result: `before` (gain, radius, baseline, k, limit kept) with the trim of the
/// commanded right/left speed ratio `ratio`, and each wheel's fitted offset when compensating
/// (the guess in `before` while a wheel's line is not fitted; 0 when not compensating).
KinematicsParams calibratedKinematics(const KinematicsParams& before, double ratio,
                                      const MotorFitter& fit, bool compensate_deadband);

/// Adds a drive to the motor fit. When the fit moves the offsets, the estimator's k is rebased so
/// that a drive at drive_speed_mps is commanded with the duties it was before: k was learned
/// through the old offsets (first the camera stage's guesses), and the same k through new offsets
/// is another pair of duties. Without this, guesses that differ from the fitted offsets by a few
/// hundredths (0.11/0.13 for 0.08/0.08) make the next drive turn by tens of degrees.
void addDriveToFit(const DriveRecord& drive, int ticks_per_revolution,
                   const KinematicsParams& before, double drive_speed_mps, MotorFitter& fit,
                   TrimEstimator& estimator);

/// The first guesses of the two deadbands [duty] from the camera stage's minimum moving duties.
/// The probe finds each only to its duty step (and the tick the wheel rested on), so two minima
/// within `resolution` of each other are one deadband seen twice: both wheels get their mean. Two
/// different guesses for equal deadbands bias the first drives' speed ratio (0.10/0.11 for 0.08
/// and 0.08: 3 %, the first drive measured with the wrong sign; addDriveToFit rebases the ratio
/// when the fitted deadbands replace the guesses). Minima further apart are two different
/// deadbands and are kept.
struct DeadbandGuesses {
  double left = 0, right = 0;
};
DeadbandGuesses deadbandGuesses(double min_duty_left, double min_duty_right, double resolution);
/// The wheel stage's first guesses: `configured` for both wheels when it is >= 0; else the camera
/// stage's minimum moving duties (negative: unknown) through deadbandGuesses when both are known;
/// else each wheel's known one, or the kinematics file's offset (`before`).
DeadbandGuesses firstDeadbandGuesses(double configured, double camera_min_duty_left,
                                     double camera_min_duty_right, double resolution,
                                     const KinematicsParams& before);

class WheelRun : public Stage {
 public:
  /// Throws ConfigError on bad options or intrinsics.
  WheelRun(const WheelRunOptions& options, const CameraIntrinsics& intrinsics);
  ~WheelRun();

  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution,
                   double now_s) override;
  void noteEncodersArrived(double now_s) override;
  void noteFrameArrived(double now_s) override;
  /// Whether a frame stamped `stamp_s` is wanted (others are dropped unprocessed).
  bool wantsFrame(double stamp_s) const override;
  /// Detects the tags of a wanted frame. Throws InputError on a bad image.
  void addFrame(double stamp_s, const cv::Mat& image);
  /// Stage input: addFrame above; the last frame of the extrinsics' stills is kept for the ground
  /// view drawn beside the extrinsics file.
  bool addFrame(double stamp_s, const cv::Mat& image, const std::string& source) override;
  /// Advances the run; returns the duties to command now (zero when done or failed).
  WheelDuties update(double now_s) override;

  WheelRunStage stage() const { return stage_; }
  bool done() const override { return stage_ == WheelRunStage::kDone; }
  bool failed() const { return stage_ == WheelRunStage::kFailed; }
  const std::string& failure() const { return failure_; }

  /// The calibrated kinematics (valid once the iteration converged): trim from the ratio, the
  /// fitted offsets when compensating.
  KinematicsParams result() const;
  const TrimEstimator& estimator() const { return estimator_; }
  const MotorFit& motorFit(bool left) const { return left ? fitter_.left() : fitter_.right(); }
  /// The last heading measured [rad] (NaN before the first).
  double lastHeadingRad() const { return last_heading_rad_; }
  /// The camera's mount from the floor tags, once the turns for it are done (extrinsics_spins >
  /// 0); nullptr before, or when it failed (extrinsicsFailure() says why: the stage goes on).
  const extrinsics::TagMountResult* extrinsicsResult() const {
    return extrinsics_done_ && extrinsics_failure_.empty() ? &extrinsics_result_ : nullptr;
  }
  const std::string& extrinsicsFailure() const { return extrinsics_failure_; }
  /// Tags detected in the last processed frame.
  const std::vector<markers::TagDetection>& lastDetections() const { return last_detections_; }
  double elapsedS() const { return started_ ? last_now_s_ - start_s_ : 0.0; }
  /// 0..1, a rough share of the stage done.
  double progress() const;
  /// One line: stage, step, k, last Δθ, heading.
  std::string describe() const;
  /// Step: the stage; key: the drives so far (each is logged).
  StageStatus status() const override;
  /// Writes <calibration_root>/kinematics/<veh>.yaml (validated first) and, when the mount was
  /// measured, camera_extrinsic/<veh>.yaml with its ground view; the DONE says why extrinsics are
  /// missing. Valid once done().
  StageResult finish(const StageOutput& output) override;

 private:
  /// The deadbands are compensated but some wheel's line has not formed yet.
  bool motorFitPending() const;
  enum class Motion { kNone, kPulse, kSpin, kDrive, kSettle, kMeasure };
  enum class Purpose {
    kAlign,
    kBeforeDrive,
    kAfterForward,
    kAfterDrive,
    kAfterBack,
    kLeaveDrive,
    kSpin
  };

  void fail(const std::string& why);
  void startAlign(WheelRunStage then);
  void startMeasure(Purpose purpose, double now_s);
  void startPulse(double turn_rad);
  void startDrive(double now_s, int sign, double speed_mps);
  void stopMotion(double now_s);
  /// A drive back's duties for now: the base duties corrected so that the wheels retrace the
  /// forward drive (back_steer_s).
  void steerBack(double now_s);
  void startMotionClock(double length_s);
  /// The leave's duties for now: straight, or steered onto the tag line by the last frame.
  void steerLeave(double now_s);
  bool settled(double now_s) const;
  /// The duties of a drive back at the speed these forward duties drive (the motor fit's slopes
  /// per direction, once it has them; else the same).
  WheelDuties backwardDuties(const WheelDuties& forward) const;
  void onMeasured(double now_s);
  void onSettled(double now_s);
  void recordDriveForFit();
  void startLeave(double now_s);
  void startSpin();
  /// The extrinsics' short straight drives: forward, then back to where they began.
  void startExtrinsicsDrive(double now_s);
  /// Between passes of hops: back to half a hop behind where the pass began.
  void startExtrinsicsReturn(double now_s);
  /// A measurement ended: its tags become a still of the extrinsics, paired with the one before
  /// when a drive or a turn on the spot lay between them.
  void recordStill();
  /// The mount from the stills so far: extrinsics_result_, or why it is refused in
  /// extrinsics_failure_.
  void judgeMount();
  KinematicsParams driveParams() const;
  double driveSeconds(double speed_mps) const;
  double driveDistanceM() const;

  WheelRunOptions options_;
  std::unique_ptr<markers::TagDetector> detector_;
  TrimEstimator estimator_;
  WheelRunStage stage_ = WheelRunStage::kWaitForData;
  WheelRunStage after_align_ = WheelRunStage::kIterate;
  Motion motion_ = Motion::kNone;
  Purpose purpose_ = Purpose::kAlign;
  std::string failure_;

  // clock and inputs
  bool started_ = false;
  double start_s_ = 0, last_now_s_ = 0;
  bool have_frame_ = false;
  int updates_without_frames_ = 0, updates_without_encoders_ = 0;
  EncoderTracker encoders_;
  int ticks_per_rev_ = 0;

  // motion
  WheelDuties duties_;
  double motion_end_s_ = 0, stop_s_ = -1e9;
  double motion_len_s_ = 0;
  bool motion_clock_started_ = true;
  int drive_sign_ = 0;
  double drive_speed_mps_ = 0;
  int back_drives_ = 0;            ///< drives back started
  KinematicsParams drive_params_;  // what the last forward drive drove with
  double forward_s_ = 0;           // its commanded length
  double drive_forward_m_ = 0;     // its distance by the encoders
  double creep_m_ = 0;             // where the drives left the robot, along them, by the encoders
  double ratio_error_ = 0;
  int drive_start_left_ = 0, drive_start_right_ = 0;
  DriveRecord drive_;  // the current (last) drive's duties, times and encoder readings
  MotorFitter fitter_;

  // measuring
  std::vector<TagSighting> sightings_;
  int frames_in_measurement_ = 0, frames_without_tags_ = 0;
  double measure_from_s_ = 0;
  double last_heading_rad_;
  double heading_before_drive_ = 0;
  double drive_left_angle_rad_ = 0;
  double drive_right_angle_rad_ = 0;
  // steering the drive back: the forward drive's right/left wheel-angle ratio (0: not steered),
  // the nominal wheel speed [rad/s], the deviation's integral [rad s], the last update's time
  double steer_ratio_ = 0, steer_wheel_radps_ = 0, steer_integral_ = 0, steer_last_s_ = 0;
  /// The integral's correction each speed's last steered drive back ended with (0: the drive
  /// speed, 1: the other back speed) [share].
  double steer_carried_[2] = {0, 0};
  int steer_slot_ = 0;
  std::vector<markers::TagDetection> last_detections_;
  /// The last frame of the extrinsics' stills (the ground view beside the extrinsics file).
  cv::Mat ground_frame_;

  // aligning
  int align_steps_ = 0;
  double search_turned_rad_ = 0;
  int pulse_ticks_ = 1;
  double last_frame_arrival_s_ = -1e300;  ///< on the caller's clock
  /// The pulse's ticks less the wheel's measured turn past the end of a pulse (an average).
  int pulse_stop_ticks_ = 1;
  double pulse_overshoot_ticks_ = 0;
  bool overshoot_measured_ = false, pulse_by_ticks_ = false;
  int pulse_dir_ = 0;  // +1 ccw, -1 cw
  int pulse_start_right_ = 0;
  double turn_duty_boost_ = 0;

  // iterating / leaving
  int iteration_ = 0;
  int fit_cycles_ = 0;  ///< drives forward and back for the motor fit after the trim converged
  int drives_without_tags_ = 0;
  /// Turning steps were made since the last drive forward; the drive under way follows them.
  bool pulsed_since_drive_ = false;
  bool settling_drive_ = false;
  int settled_iteration_ = -1;  ///< the iteration_ the last settling drive was made at
  double last_delta_theta_rad_ = 0;
  double leave_start_left_ = 0;
  double last_tag_seen_s_ = 0;
  bool leave_clear_ = false;
  int leave_clear_left_ = 0;
  // The last frame's heading and lateral offset from the tag line while leaving, and its stamp.
  double leave_heading_rad_ = 0, leave_lateral_m_ = 0;
  double leave_sighted_s_ = -std::numeric_limits<double>::infinity();

  // extrinsics
  std::vector<extrinsics::TagSeen> still_tags_;  ///< of the measurement under way
  std::vector<extrinsics::TagStill> stills_;
  std::vector<extrinsics::StillPair> still_pairs_;
  /// What the robot did since the last still (none: nothing the extrinsics can use).
  enum class SinceStill { kNone, kForward, kBackward, kSpin };
  SinceStill since_still_ = SinceStill::kNone;
  int spins_done_ = 0;
  bool aligned_for_hops_ = false;
  int extrinsics_drives_done_ = 0;  ///< of the pass under way
  int extrinsics_pass_ = 0;
  /// Both encoders' mean raw count where the pass's first hop began.
  double pass_start_ticks_ = 0;
  // The alignment's last heading (NaN before its first).
  double align_prev_heading_rad_ = std::numeric_limits<double>::quiet_NaN();
  int spin_side_ = 1;  ///< +1: the first turn counter-clockwise (the tags to the left)
  int spin_start_right_ = 0, spin_ticks_ = 1;
  bool extrinsics_done_ = false;
  extrinsics::TagMountResult extrinsics_result_;
  std::string extrinsics_failure_;
};

}  // namespace wheels
}  // namespace autocal
