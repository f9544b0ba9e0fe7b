// The wheel stage's loop: align (paper 000 §3.3), iterate (§3.4), leave (§5.1).
#include "autocal/wheels/wheel_run.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace wheels {

namespace {
/// Silence counts only over this many updates in a row without a message: a node that was not
/// scheduled for a while is not mistaken for a dead sensor.
constexpr int kSilentUpdates = 10;
/// A turning pulse ends early by the wheel's measured turn past its end once that is this many
/// ticks or more (a robot whose commands and readings come late).
constexpr double kPulseOvershootTicks = 4.0;
/// The largest share of a forward drive by which a drive back is lengthened or shortened to make
/// up for where the earlier cycles left the robot (WheelRun::onMeasured).
constexpr double kMaxCreepShare = 0.25;
/// Creep within this distance is left alone [m] (in the simulator's core, without a lag, the
/// cycles creep by 0.1 m at most, from the first drives' deadband guess): a robot that keeps to its
/// commands drives its cycles as the paper does.
constexpr double kCreepDeadzoneM = 0.15;
std::string deg(double rad) { return formatNumber(rad * 180.0 / M_PI, 3) + " deg"; }
}  // namespace

const char* name(WheelRunStage stage) {
  switch (stage) {
    case WheelRunStage::kWaitForData:
      return "wait";
    case WheelRunStage::kAlign:
      return "align";
    case WheelRunStage::kIterate:
      return "iterate";
    case WheelRunStage::kExtrinsics:
      return "extrinsics";
    case WheelRunStage::kLeave:
      return "leave";
    case WheelRunStage::kDone:
      return "done";
    case WheelRunStage::kFailed:
      return "failed";
  }
  return "?";
}

void WheelRunOptions::validate() const {
  if (extrinsics_spins < 0 || extrinsics_spins > 20)
    throw ConfigError("extrinsics_spins: must be within [0, 20]");
  if (!(extrinsics_spin_rad >= 0.1 && extrinsics_spin_rad <= 0.6))
    throw ConfigError("extrinsics_spin_rad: must be within [0.1, 0.6] [rad]");
  if (!(extrinsics_drive_m >= 0 && extrinsics_drive_m <= 0.5))
    throw ConfigError("extrinsics_drive_m: must be within [0, 0.5] [m]");
  if (extrinsics_drives < 0 || extrinsics_drives > 20)
    throw ConfigError("extrinsics_drives: must be within [0, 20]");
  if (extrinsics_drives_back < 0 || extrinsics_drives_back > 20)
    throw ConfigError("extrinsics_drives_back: must be within [0, 20]");
  if (extrinsics_passes < 1 || extrinsics_passes > 5)
    throw ConfigError("extrinsics_passes: must be within [1, 5]");
  if (extrinsics_max_passes < 1 || extrinsics_max_passes > 5)
    throw ConfigError("extrinsics_max_passes: must be within [1, 5]");
  if (extrinsics_spins > 0 && extrinsics_drive_m > 0 && extrinsics_drives > 0 &&
      (extrinsics_min_hops < 1 || extrinsics_min_hops > extrinsics_drives - 1)) {
    throw ConfigError(
        "extrinsics_min_hops: must be within [1, extrinsics_drives - 1] (the first hop forward "
        "gives no yaw)");
  }
  if (!(extrinsics_max_floor_sigma_m > 0))
    throw ConfigError("extrinsics_max_floor_sigma_m: must be > 0 [m]");
  if (!(extrinsics_max_yaw_sigma_rad > 0))
    throw ConfigError("extrinsics_max_yaw_sigma_rad: must be > 0 [rad]");
  if (extrinsics_spins > 0) extrinsics.validate();
  detector.validate();
  heading.validate();
  mount.validate();
  trim.validate();
  kinematics.validate();
  if (!(drive_speed_mps > 0 && drive_speed_mps <= kinematics.v_max))
    throw ConfigError("drive_speed_mps: must be within (0, v_max] [m/s]");
  if (!(back_speed_mps > 0 && back_speed_mps <= kinematics.v_max))
    throw ConfigError("back_speed_mps: must be within (0, v_max] [m/s]");
  if (compensate_deadband && std::abs(back_speed_mps - drive_speed_mps) < 0.05) {
    throw ConfigError(
        "back_speed_mps: must differ from drive_speed_mps by 0.05 m/s or more to fit the deadband");
  }
  if (!(back_steer_s == 0 || (back_steer_s >= 0.1 && back_steer_s <= 5)))
    throw ConfigError("back_steer_s: must be 0 (not steered) or within [0.1, 5] [s]");
  if (!(max_back_steer > 0 && max_back_steer <= 0.5))
    throw ConfigError("max_back_steer: must be within (0, 0.5]");
  if (!(max_fit_cycles >= 0 && max_fit_cycles <= 20))
    throw ConfigError("max_fit_cycles: must be within [0, 20]");
  if (!(drive_s > 0.3 && drive_s < 20)) throw ConfigError("drive_s: must be within (0.3, 20) [s]");
  if (!(min_fit_window_s > 0 && min_fit_window_s <= drive_s - motor_settle_s))
    throw ConfigError("min_fit_window_s: must be within (0, drive_s - motor_settle_s] [s]");
  if (fit_drives < 2) throw ConfigError("fit_drives: must be >= 2 (a line needs two speeds)");
  if (!(max_fit_residual > 0)) throw ConfigError("max_fit_residual: must be > 0");
  if (!(min_drive_s > 0 && min_drive_s <= drive_s))
    throw ConfigError("min_drive_s: must be within (0, drive_s] [s]");
  if (!(max_drive_turn_rad > 0 && max_drive_turn_rad < 1))
    throw ConfigError("max_drive_turn_rad: must be within (0, 1) [rad]");
  if (!(initial_ratio_error > 0 && initial_ratio_error < 1))
    throw ConfigError("initial_ratio_error: must be within (0, 1)");
  if (!(motor_settle_s >= 0 && motor_settle_s < min_drive_s - 0.15))
    throw ConfigError("motor_settle_s: must be within [0, min_drive_s - 0.15) [s]");
  if (!(align_tolerance_rad > 0 && align_tolerance_rad < 0.5))
    throw ConfigError("align_tolerance_rad: must be within (0, 0.5)");
  if (!(realign_above_rad > align_tolerance_rad))
    throw ConfigError("realign_above_rad: must exceed align_tolerance_rad");
  if (!(turn_duty_margin > 0 && turn_duty_margin < 0.5))
    throw ConfigError("turn_duty_margin: must be within (0, 0.5)");
  if (!(max_pulse_s > 0 && max_pulse_s <= 5))
    throw ConfigError("max_pulse_s: must be within (0, 5] [s]");
  if (!(search_step_rad > 0 && search_step_rad < 1.0))
    throw ConfigError("search_step_rad: must be within (0, 1) [rad]");
  if (!(max_search_turn_rad > 0)) throw ConfigError("max_search_turn_rad: must be > 0");
  if (max_align_steps < 1) throw ConfigError("max_align_steps: must be >= 1");
  if (!(still_s > 0) || !(settle_s >= 0))
    throw ConfigError("still_s/settle_s: must be > 0 / >= 0 [s]");
  if (heading_frames < 1) throw ConfigError("heading_frames: must be >= 1");
  if (max_frames_without_tags < 1) throw ConfigError("max_frames_without_tags: must be >= 1");
  if (!(leave_speed_mps > 0 && leave_speed_mps <= kinematics.v_max))
    throw ConfigError("leave_speed_mps: must be within (0, v_max]");
  if (!(leave_clear_s > 0)) throw ConfigError("leave_clear_s: must be > 0 [s]");
  if (leave_clear_frames < 1) throw ConfigError("leave_clear_frames: must be >= 1");
  if (!(exit_extra_m >= 0)) throw ConfigError("exit_extra_m: must be >= 0 [m]");
  if (!(max_leave_m > exit_extra_m)) throw ConfigError("max_leave_m: must exceed exit_extra_m [m]");
  if (!(leave_lateral_gain_rad_per_m >= 0 && leave_heading_gain_per_s >= 0))
    throw ConfigError("leave_lateral_gain_rad_per_m/leave_heading_gain_per_s: must be >= 0");
  if (!(leave_max_correction_rad >= 0 && leave_max_correction_rad < M_PI / 2))
    throw ConfigError("leave_max_correction_rad: must be within [0, pi/2) [rad]");
  if (!(leave_steer_max_age_s > 0)) throw ConfigError("leave_steer_max_age_s: must be > 0 [s]");
  if (!(camera_timeout_s > 0 && encoder_timeout_s > 0 && max_duration_s > 0))
    throw ConfigError("camera_timeout_s/encoder_timeout_s/max_duration_s: must be > 0 [s]");
}

std::unique_ptr<markers::TagDetector> makeFloorTagDetector(const WheelRunOptions& options,
                                                           const CameraIntrinsics& intrinsics) {
  markers::TagDetectorOptions detector = options.detector;
  if (options.crop_to_floor && detector.min_row_px == 0) {
    // A 12 px margin: a tag's far corners and the lens model's error.
    detector.min_row_px =
        std::max(0, floorRowLimitPx(options.mount, intrinsics.fy, intrinsics.cy, intrinsics.height,
                                    options.heading.max_distance_m + detector.tag_size_m) -
                        12);
  }
  auto d = std::make_unique<markers::TagDetector>(detector, intrinsics);
  d->setFloorNormal(options.mount.floorUpInCamera());
  return d;
}

WheelRun::WheelRun(const WheelRunOptions& options, const CameraIntrinsics& intrinsics)
    : options_(options),
      detector_(makeFloorTagDetector((options.validate(), options), intrinsics)),
      estimator_(options.trim),
      fitter_(motorFitOptions(options)),
      last_heading_rad_(std::numeric_limits<double>::quiet_NaN()) {
  ratio_error_ = options_.initial_ratio_error;
}

WheelRun::~WheelRun() = default;

void WheelRun::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                           int ticks_per_revolution, double now_s) {
  if (ticks_per_revolution <= 0)
    throw InputError("encoder resolution must be > 0 ticks per revolution");
  (void)now_s;
  updates_without_encoders_ = 0;
  if (!encoders_.add(stamp_s, left_ticks, right_ticks).accepted) return;
  ticks_per_rev_ = ticks_per_revolution;
  if (motion_ == Motion::kDrive)
    drive_.samples.push_back({stamp_s, double(left_ticks), double(right_ticks)});
}

void WheelRun::noteEncodersArrived(double) { updates_without_encoders_ = 0; }

void WheelRun::noteFrameArrived(double now_s) {
  last_frame_arrival_s_ = now_s;
  have_frame_ = true;
  updates_without_frames_ = 0;
}

bool WheelRun::wantsFrame(double stamp_s) const {
  if (motion_ == Motion::kMeasure) return stamp_s >= measure_from_s_;
  return stage_ == WheelRunStage::kLeave && motion_ == Motion::kDrive;
}

void WheelRun::fail(const std::string& why) {
  stage_ = WheelRunStage::kFailed;
  failure_ = why;
  duties_ = {};
  motion_ = Motion::kNone;
  throw CalibrationError(why);
}

MotorFitOptions motorFitOptions(const WheelRunOptions& o) {
  MotorFitOptions m;
  m.motor_settle_s = o.motor_settle_s;
  m.min_fit_window_s = o.min_fit_window_s;
  m.fit_drives = o.fit_drives;
  m.max_fit_residual = o.max_fit_residual;
  return m;
}

KinematicsParams calibratedKinematics(const KinematicsParams& before, double ratio,
                                      const MotorFitter& fit, bool compensate_deadband) {
  KinematicsParams p = before;
  p.trim = trimFromSpeedRatio(ratio, p.gain);
  if (!compensate_deadband) {
    p.deadband_left = p.deadband_right = 0;
  } else {
    if (fit.left().valid) p.deadband_left = fit.left().offset;
    if (fit.right().valid) p.deadband_right = fit.right().offset;
  }
  return p;
}

void addDriveToFit(const DriveRecord& drive, int ticks_per_revolution,
                   const KinematicsParams& before, double drive_speed_mps, MotorFitter& fit,
                   TrimEstimator& estimator) {
  const KinematicsParams old_params =
      calibratedKinematics(before, estimator.ratio(), fit, /*compensate_deadband=*/true);
  const double w = drive_speed_mps / old_params.radius;
  const WheelDuties duties = speedsToDuties(old_params, {w, w});
  fit.addDrive(drive, ticks_per_revolution);
  const KinematicsParams p =
      calibratedKinematics(before, estimator.ratio(), fit, /*compensate_deadband=*/true);
  if (p.deadband_left == old_params.deadband_left && p.deadband_right == old_params.deadband_right)
    return;
  // The same duties above the new offsets: u_r/u_l = (gain + trim)/(gain - trim) = k.
  const double u_left = removeDeadband(duties.left, p.deadband_left);
  const double u_right = removeDeadband(duties.right, p.deadband_right);
  if (u_left > 0 && u_right > 0) estimator.rebase(u_right / u_left);
}

DeadbandGuesses deadbandGuesses(double min_duty_left, double min_duty_right, double resolution) {
  if (std::abs(min_duty_left - min_duty_right) <= resolution + 1e-9) {
    const double mean = 0.5 * (min_duty_left + min_duty_right);
    return {mean, mean};
  }
  return {min_duty_left, min_duty_right};
}

DeadbandGuesses firstDeadbandGuesses(double configured, double camera_min_duty_left,
                                     double camera_min_duty_right, double resolution,
                                     const KinematicsParams& before) {
  if (configured >= 0) return {configured, configured};
  if (camera_min_duty_left >= 0 && camera_min_duty_right >= 0)
    return deadbandGuesses(camera_min_duty_left, camera_min_duty_right, resolution);
  return {camera_min_duty_left >= 0 ? camera_min_duty_left : before.deadband_left,
          camera_min_duty_right >= 0 ? camera_min_duty_right : before.deadband_right};
}

WheelDuties WheelRun::backwardDuties(const WheelDuties& forward) const {
  // The kinematics drive forward straight; a motor faster backward than forward (the fit's
  // slopes per direction) gets its duty above the deadband scaled down by as much.
  const auto scaled = [](double duty, const MotorFit& f) {
    if (!f.valid || !f.per_direction || duty <= f.offset) return duty;
    return f.offset + (duty - f.offset) * f.slope / f.backward_slope;
  };
  if (!options_.compensate_deadband) return forward;
  return {scaled(forward.left, fitter_.left()), scaled(forward.right, fitter_.right())};
}

KinematicsParams WheelRun::driveParams() const {
  return calibratedKinematics(options_.kinematics, estimator_.ratio(), fitter_,
                              options_.compensate_deadband);
}

KinematicsParams WheelRun::result() const { return driveParams(); }

bool WheelRun::motorFitPending() const {
  return options_.compensate_deadband && !(fitter_.left().valid && fitter_.right().valid);
}

double WheelRun::driveSeconds(double speed_mps) const {
  // A ratio error e turns the robot by about e·distance/baseline over a drive.
  // Until both deadbands are fitted the ratio depends on the speed, and the next drive's speed
  // differs from the last one's: expect at least 5 %.
  const bool fitted =
      !options_.compensate_deadband || (fitter_.left().valid && fitter_.right().valid);
  const double error = fitted ? ratio_error_ : std::max(ratio_error_, 0.05);
  const double s = options_.max_drive_turn_rad * options_.kinematics.baseline / (error * speed_mps);
  return std::clamp(s, options_.min_drive_s, options_.drive_s);
}

void WheelRun::startMeasure(Purpose purpose, double now_s) {
  motion_ = Motion::kMeasure;
  purpose_ = purpose;
  duties_ = {};
  sightings_.clear();
  still_tags_.clear();
  frames_in_measurement_ = 0;
  frames_without_tags_ = 0;
  measure_from_s_ = now_s;
}

void WheelRun::startAlign(WheelRunStage then) {
  stage_ = WheelRunStage::kAlign;
  after_align_ = then;
  align_steps_ = 0;
  search_turned_rad_ = 0;
  align_prev_heading_rad_ = std::numeric_limits<double>::quiet_NaN();
  startMeasure(Purpose::kAlign, last_now_s_);
}

void WheelRun::startPulse(double turn_rad) {
  // Paper §3.2–3.3: one wheel turns, the other stands (here the right wheel drives and the robot
  // pivots on the left wheel, so it stays where it is over any number of steps). The pulse ends
  // when the right encoder has turned the wheel by the step's angle, R·φ/L = turn (at least one
  // tick), not after a fixed time: a command's delay (a loaded machine, a simulator ahead of real
  // time) would change a timed step's length; max_pulse_s bounds it.
  const double offset = std::max(driveParams().deadband_right, options_.kinematics.deadband_right);
  const double duty = std::min(0.9, offset + options_.turn_duty_margin + turn_duty_boost_);
  duties_ = {0.0, pulse_dir_ * duty};
  motion_ = Motion::kPulse;
  pulsed_since_drive_ = true;
  since_still_ = SinceStill::kNone;  // a pivot on the left wheel, not about the axle
  pulse_start_right_ = encoders_.rawRight();
  const double wheel_rad = turn_rad * options_.kinematics.baseline / options_.kinematics.radius;
  pulse_ticks_ =
      std::max(1, static_cast<int>(std::lround(wheel_rad * ticks_per_rev_ / (2 * M_PI))));
  // The wheel turns on past the tick the pulse ends at: the command reaches the motor late, the
  // encoder reading comes late, and the wheel coasts. The pulse ends that many ticks early, as
  // the steps before measured it.
  // A tick or two of coasting is no lag worth it (kPulseOvershootTicks).
  const int early = pulse_overshoot_ticks_ >= kPulseOvershootTicks
                        ? static_cast<int>(std::lround(pulse_overshoot_ticks_))
                        : 0;
  pulse_stop_ticks_ = std::max(1, pulse_ticks_ - early);
  startMotionClock(options_.max_pulse_s);
  purpose_ = Purpose::kAlign;
}

void WheelRun::startDrive(double now_s, int sign, double speed_mps) {
  if (sign > 0) {
    // A re-alignment's steps turned the right wheel alone: the wheels start the next drive with
    // their gearboxes' backlash taken up on opposite sides, and the robot turns by degrees as it
    // starts (3.8 deg on a robot-mode run, for 0.5 over the rest of a 0.9 m drive). Such a drive
    // takes up the backlash and updates nothing (once per update: a settling drive that turned
    // beyond realign_above_rad is followed by another re-alignment).
    settling_drive_ = pulsed_since_drive_ && iteration_ > 0 && settled_iteration_ != iteration_;
    if (settling_drive_) settled_iteration_ = iteration_;
    pulsed_since_drive_ = false;
  }
  since_still_ = sign > 0 ? SinceStill::kForward : SinceStill::kBackward;
  const KinematicsParams p = drive_params_ = driveParams();
  const double w = speed_mps / p.radius;
  const WheelDuties d = speedsToDuties(p, {w, w});
  drive_sign_ = sign;
  drive_speed_mps_ = speed_mps;
  steer_ratio_ = 0;
  duties_ = {sign * d.left, sign * d.right};
  motion_ = Motion::kDrive;
  drive_ = DriveRecord();
  drive_.duties = d;
  drive_.start_s = now_s;
  drive_start_left_ = encoders_.rawLeft();
  drive_start_right_ = encoders_.rawRight();
  startMotionClock(driveSeconds(speed_mps));
}

void WheelRun::startSpin() {
  // Turns of one step towards the side the tags are on and back, and again: the view swings
  // between the heading the robot stood at and one step towards the tags, so that the tags stay
  // in view before and after every turn even when the drives left the robot beside the strip (a
  // turn away from it loses them).
  if (spins_done_ == 0) {
    double y_sum = 0;
    for (const TagSighting& t : sightings_) y_sum += t.y_m;
    spin_side_ = y_sum < 0 ? -1 : 1;  // tags to the right: turn clockwise first
  }
  const double turn = (spins_done_ % 2 == 0 ? 1 : -1) * spin_side_ * options_.extrinsics_spin_rad;
  ++spins_done_;
  // Both wheels at the same speed, opposite ways (the calibrated kinematics): the robot turns
  // about the middle of its axle. It stops when the right wheel has turned by the turn's share,
  // R·φ = turn·L/2; how far it really turned the tags measure.
  const KinematicsParams p = driveParams();
  const double w = std::copysign(0.1 / p.radius, turn);
  const WheelDuties d = speedsToDuties(p, {-w, w});
  duties_ = d;
  motion_ = Motion::kSpin;
  purpose_ = Purpose::kSpin;
  since_still_ = SinceStill::kSpin;
  spin_start_right_ = encoders_.rawRight();
  const double wheel_rad = std::abs(turn) * 0.5 * p.baseline / p.radius;
  spin_ticks_ = std::max(1, static_cast<int>(std::lround(wheel_rad * ticks_per_rev_ / (2 * M_PI))));
  startMotionClock(3 * options_.max_pulse_s);
}

void WheelRun::startExtrinsicsDrive(double now_s) {
  const int sign = extrinsics_drives_done_ < options_.extrinsics_drives ? +1 : -1;
  if (extrinsics_drives_done_ == 0)
    pass_start_ticks_ = 0.5 * (encoders_.rawLeft() + encoders_.rawRight());
  ++extrinsics_drives_done_;
  startDrive(now_s, sign, options_.drive_speed_mps);
  startMotionClock(options_.extrinsics_drive_m / options_.drive_speed_mps);
  purpose_ = Purpose::kSpin;  // a still follows, as after a turn
}

void WheelRun::startExtrinsicsReturn(double now_s) {
  // Half a hop behind the pass's start: the next pass's stills see the tags half a hop from
  // where this pass's saw them, and its hops end half a hop short of this pass's end, on the tags
  // it found. The drive back is unsteered, with the motor fit's duties per direction (as the
  // iteration's drives back once it tells the directions apart); it takes no part in the mount.
  const double ticks = 0.5 * (encoders_.rawLeft() + encoders_.rawRight()) - pass_start_ticks_;
  const double forward_m = ticks * 2 * M_PI / ticks_per_rev_ * options_.kinematics.radius;
  const double back_m = std::max(0.0, forward_m) + 0.5 * options_.extrinsics_drive_m;
  ++extrinsics_pass_;
  extrinsics_drives_done_ = 0;
  aligned_for_hops_ = false;  // the drive back turns the robot by a degree or more: align again
  startDrive(now_s, -1, options_.drive_speed_mps);
  const WheelDuties d = backwardDuties(drive_.duties);
  duties_ = {-d.left, -d.right};
  drive_.duties = d;
  drive_.backward = true;
  startMotionClock(back_m / options_.drive_speed_mps);
  purpose_ = Purpose::kSpin;  // a still follows (it pairs with no other: no tag stays in view)
}

void WheelRun::recordStill() {
  stills_.push_back({still_tags_});
  const int now = static_cast<int>(stills_.size()) - 1;
  if (now > 0 && since_still_ != SinceStill::kNone) {
    const extrinsics::StillMotion m =
        since_still_ == SinceStill::kForward    ? extrinsics::StillMotion::kForward
        : since_still_ == SinceStill::kBackward ? extrinsics::StillMotion::kBackward
                                                : extrinsics::StillMotion::kSpin;
    // The stage's own short hops forward come after the trim converged: straight, but for the
    // first. The turns on the spot and the alignment's steps before it left each wheel's gearbox
    // play taken up the way that wheel last turned: the first hop starts with a wheel crossing
    // its play while the other drives, a turn made at the start rather than along the hop, whose
    // chord is then not at half the turn. It takes the play up on both wheels; its stills count,
    // its drive not for the yaw. The hops back are not known to be straight: the trim was fitted
    // forward, and a robot's wheels differ backward (gains, breakaway) and cross their play again
    // at the reversal; on the robustness draws they turned by 1-6 deg, most of it at their start.
    const bool straight = stage_ == WheelRunStage::kExtrinsics &&
                          m == extrinsics::StillMotion::kForward && extrinsics_drives_done_ > 1;
    still_pairs_.push_back({now - 1, now, m, straight});
  }
  since_still_ = SinceStill::kNone;
}

void WheelRun::judgeMount() {
  extrinsics_failure_.clear();
  try {
    extrinsics::TagMountOptions mount_options = options_.extrinsics;
    if (options_.extrinsics_drive_m > 0 && options_.extrinsics_drives > 0) {
      mount_options.straight_only = true;  // the hops forward (see recordStill)
      mount_options.min_straight = options_.extrinsics_min_hops;
    }
    extrinsics_result_ = extrinsics::mountFromTags(stills_, still_pairs_, mount_options);
    const extrinsics::TagMountResult& x = extrinsics_result_;
    if (!x.has_sigma) {
      throw CalibrationError(
          "too few stills with tags to tell how sure the camera's place is (the jackknife needs "
          "3 that can each be left out)");
    }
    const double floor_sigma_m =
        extrinsics::floorSigmaM(x.mount, x.sigma, extrinsics::kFloorSigmaDistanceM);
    if (floor_sigma_m > options_.extrinsics_max_floor_sigma_m) {
      throw CalibrationError(
          "the camera's place is uncertain: one standard deviation moves a floor point " +
          formatNumber(extrinsics::kFloorSigmaDistanceM, 2) + " m ahead by " +
          formatNumber(1e3 * floor_sigma_m, 3) + " mm (yaw " + deg(x.sigma.yaw_rad) + ", y " +
          formatNumber(1e3 * x.sigma.y_m, 3) + " mm), over extrinsics_max_floor_sigma_m " +
          formatNumber(1e3 * options_.extrinsics_max_floor_sigma_m, 3) +
          " mm: the stills disagree (the straight hops' yaws spread " + deg(x.yaw_spread_rad) +
          "; a hop that did not drive straight, or a tag that moved)");
    }
    if (x.sigma.yaw_rad > options_.extrinsics_max_yaw_sigma_rad) {
      throw CalibrationError(
          "the camera's yaw is uncertain: one standard deviation of it is " +
          deg(x.sigma.yaw_rad) + ", over extrinsics_max_yaw_sigma_rad " +
          deg(options_.extrinsics_max_yaw_sigma_rad) + " (the straight hops' yaws spread " +
          deg(x.yaw_spread_rad) + "; a hop that did not drive straight, or a tag that moved)");
    }
  } catch (const Error& e) {
    extrinsics_failure_ = e.what();
  }
}

void WheelRun::startMotionClock(double length_s) {
  // A motion's clock starts at the first update() that returns its duties, i.e. when the caller
  // commands them: a motion planned while processing a frame (a node behind the simulator, a
  // slow detection) would otherwise lose the delay from its length.
  motion_len_s_ = length_s;
  motion_clock_started_ = false;
  motion_end_s_ = std::numeric_limits<double>::infinity();
}

double WheelRun::driveDistanceM() const {
  // Signed distance of the last drive by the encoders (both wheels' mean, nominal radius).
  const double ticks = 0.5 * ((encoders_.rawLeft() - drive_start_left_) +
                              (encoders_.rawRight() - drive_start_right_));
  return ticks * 2 * M_PI / ticks_per_rev_ * options_.kinematics.radius;
}

void WheelRun::stopMotion(double now_s) {
  if (motion_ == Motion::kDrive) drive_.end_s = now_s;
  duties_ = {};
  motion_ = Motion::kSettle;
  stop_s_ = now_s;
}

void WheelRun::steerBack(double now_s) {
  // The wheels' angles since the drive back began; e > 0: the right wheel is ahead of the ratio
  // the forward drive turned them in. Both wheels are corrected by a share c of their duty above
  // the offset, opposite ways, so de/dt ≈ −2·ω·c; c = (e/τ + ∫e/(2τ²))/ω makes that
  // e'' + (2/τ)·e' + e/τ² = (the motors' difference), critically damped in about τ, and the
  // integral takes up a steady difference between the motors (no deviation left at the end).
  const double rad_per_tick = 2 * M_PI / ticks_per_rev_;
  const double left = std::abs(encoders_.rawLeft() - drive_start_left_) * rad_per_tick;
  const double right = std::abs(encoders_.rawRight() - drive_start_right_) * rad_per_tick;
  const double e = right - steer_ratio_ * left;
  const double dt = std::max(0.0, now_s - steer_last_s_);
  steer_last_s_ = now_s;
  const double tau = options_.back_steer_s;
  const auto share = [&](double integral) {
    return (e / tau + integral / (2 * tau * tau)) / steer_wheel_radps_;
  };
  // Anti-windup: the integral grows only while the correction is within its bound.
  if (std::abs(share(steer_integral_ + e * dt)) < options_.max_back_steer) steer_integral_ += e * dt;
  const double c = std::clamp(share(steer_integral_), -options_.max_back_steer,
                              options_.max_back_steer);
  steer_carried_[steer_slot_] = std::clamp(steer_integral_ / (2 * tau * tau) / steer_wheel_radps_,
                                           -options_.max_back_steer, options_.max_back_steer);
  const KinematicsParams& p = drive_params_;
  const auto corrected = [&](double duty, double offset, double by) {
    if (duty <= offset) return duty;
    return std::min(p.limit, offset + (duty - offset) * (1 + by));
  };
  const WheelDuties d{corrected(drive_.duties.left, p.deadband_left, c),
                      corrected(drive_.duties.right, p.deadband_right, -c)};
  duties_ = {-d.left, -d.right};
  if (drive_.commands.empty() || drive_.commands.back()[1] != d.left ||
      drive_.commands.back()[2] != d.right)
    drive_.commands.push_back({now_s, d.left, d.right});
}

bool WheelRun::settled(double now_s) const {
  return SettleRule{options_.settle_s, options_.still_s, kMaxSettleS}.settled(stop_s_, now_s,
                                                                              encoders_);
}

void WheelRun::recordDriveForFit() {
  if (options_.compensate_deadband) {
    addDriveToFit(drive_, ticks_per_rev_, options_.kinematics, options_.drive_speed_mps, fitter_,
                  estimator_);
  }
}

void WheelRun::addFrame(double stamp_s, const cv::Mat& image) {
  last_detections_ = detector_->detect(image);
  std::vector<TagSighting> frame;
  for (const auto& d : last_detections_) frame.push_back(sightTag(d, options_.mount));
  if (stage_ == WheelRunStage::kLeave && motion_ == Motion::kDrive) {
    // Out of the tag field = no tag in leave_clear_frames processed frames in a row AND for
    // leave_clear_s on the caller's clock (a node that falls behind processes fewer frames).
    if (!last_detections_.empty()) {
      last_tag_seen_s_ = std::max(stamp_s, last_now_s_);
      frames_without_tags_ = 0;
      const HeadingMeasurement m = measureHeading(frame, options_.heading);
      const double lateral_m = measureLateralM(frame, m, options_.heading);
      if (!std::isnan(lateral_m) && stamp_s > leave_sighted_s_) {
        leave_heading_rad_ = m.heading_rad;
        leave_lateral_m_ = lateral_m;
        leave_sighted_s_ = stamp_s;
      }
    } else {
      ++frames_without_tags_;
    }
    return;
  }
  if (motion_ != Motion::kMeasure || stamp_s < measure_from_s_) return;
  ++frames_in_measurement_;
  if (options_.extrinsics_spins > 0 && !extrinsics_done_) {
    for (const markers::TagDetection& d : last_detections_) {
      extrinsics::TagSeen t;
      t.id = d.id;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) t.rotation(r, c) = d.rotation(r, c);
        t.translation_m[r] = d.translation_m[r];
      }
      t.size_m = options_.detector.tag_size_m;
      still_tags_.push_back(t);
    }
  }
  if (!measureHeading(frame, options_.heading).valid) {
    ++frames_without_tags_;
  } else {
    sightings_.insert(sightings_.end(), frame.begin(), frame.end());
  }
  const int with_tags = frames_in_measurement_ - frames_without_tags_;
  if (with_tags >= options_.heading_frames ||
      frames_without_tags_ >= options_.max_frames_without_tags) {
    // Motions start on the caller's clock: a frame arrives a while after its stamp.
    onMeasured(std::max(stamp_s, last_now_s_));
  }
}

void WheelRun::onMeasured(double now_s) {
  const HeadingMeasurement m = measureHeading(sightings_, options_.heading);
  if (m.valid) last_heading_rad_ = m.heading_rad;
  if (options_.extrinsics_spins > 0 && !extrinsics_done_) recordStill();
  switch (purpose_) {
    case Purpose::kSpin:
      if (spins_done_ < options_.extrinsics_spins) {
        startSpin();
      } else if (options_.extrinsics_drive_m > 0 &&
                 extrinsics_drives_done_ <
                     options_.extrinsics_drives + options_.extrinsics_drives_back) {
        if (extrinsics_drives_done_ == 0 && !aligned_for_hops_) {
          aligned_for_hops_ = true;
          // The turns left the robot degrees off the tag line (each turn's error adds up), and
          // hops that run off the line lose their tags: on to the line's heading first.
          startAlign(WheelRunStage::kExtrinsics);
          return;
        }
        startExtrinsicsDrive(now_s);
      } else {
        const bool hops = options_.extrinsics_drive_m > 0 &&
                          options_.extrinsics_drives + options_.extrinsics_drives_back > 0;
        if (hops && extrinsics_pass_ + 1 < options_.extrinsics_passes) {
          startExtrinsicsReturn(now_s);
          return;
        }
        judgeMount();
        if (hops && !extrinsics_failure_.empty() &&
            extrinsics_pass_ + 1 < options_.extrinsics_max_passes) {
          startExtrinsicsReturn(now_s);  // another pass before the mount is given up
          return;
        }
        if (!extrinsics_failure_.empty() && extrinsics_pass_ > 0)
          extrinsics_failure_ += " (after " + std::to_string(extrinsics_pass_ + 1) + " passes)";
        extrinsics_done_ = true;
        startAlign(WheelRunStage::kLeave);
      }
      return;
    case Purpose::kAlign: {
      if (++align_steps_ > options_.max_align_steps) {
        fail("could not align with the floor tags in " + std::to_string(options_.max_align_steps) +
             " turning steps (last heading " + deg(last_heading_rad_) + ")");
      }
      if (!m.valid) {
        // Paper §3.3: turn step by step until a tag is in view; the direction does not matter.
        if (search_turned_rad_ > options_.max_search_turn_rad) {
          fail("no floor tag in view over a full turn (turned " + deg(search_turned_rad_) +
               "): is the robot at the tag field, and the camera working?");
        }
        pulse_dir_ = 1;
        startPulse(options_.search_step_rad);
        return;
      }
      search_turned_rad_ = 0;
      // Beyond the paper: when the last step overshot (the heading changed sign), the smallest
      // step the robot makes may be larger than the tolerance window (static friction, a command
      // that reaches the motor late); it would turn back and forth. Within half that step (at
      // most twice the tolerance) the robot is as aligned as its steps allow.
      double tolerance = options_.align_tolerance_rad;
      if (std::isfinite(align_prev_heading_rad_) &&
          (align_prev_heading_rad_ > 0) != (m.heading_rad > 0)) {
        const double step = std::abs(wrapAngle(m.heading_rad - align_prev_heading_rad_));
        tolerance = std::clamp(0.5 * step, tolerance, 2 * options_.align_tolerance_rad);
      }
      align_prev_heading_rad_ = m.heading_rad;
      if (std::abs(m.heading_rad) < tolerance) {
        if (after_align_ == WheelRunStage::kLeave) {
          stage_ = WheelRunStage::kLeave;
          startLeave(now_s);
        } else if (after_align_ == WheelRunStage::kExtrinsics) {
          stage_ = WheelRunStage::kExtrinsics;
          if (spins_done_ < options_.extrinsics_spins) {
            startSpin();
          } else {
            startExtrinsicsDrive(now_s);
          }
        } else {
          stage_ = WheelRunStage::kIterate;
          heading_before_drive_ = m.heading_rad;
          startDrive(now_s, +1, options_.drive_speed_mps);
        }
        return;
      }
      // Turn towards heading 0: a positive heading is the robot turned counter-clockwise.
      pulse_dir_ = m.heading_rad > 0 ? -1 : 1;
      startPulse(0.8 * std::abs(m.heading_rad));
      return;
    }
    case Purpose::kBeforeDrive:
      if (!m.valid || std::abs(m.heading_rad) > options_.realign_above_rad) {
        startAlign(WheelRunStage::kIterate);
        return;
      }
      heading_before_drive_ = m.heading_rad;
      startDrive(now_s, +1, options_.drive_speed_mps);
      return;
    case Purpose::kAfterDrive:
      if (!m.valid) {
        ratio_error_ =
            std::min(options_.initial_ratio_error, 4 * ratio_error_);  // drive shorter next time
        if (++drives_without_tags_ >= 3) {
          fail("the floor tags were lost after " + std::to_string(drives_without_tags_) +
               " drives in a row: the tag field is too short for drive_s, or the robot leaves it");
        }
      } else if (estimator_.converged() || settling_drive_) {
        // A drive for the motor fit alone (motorFitPending): the trim is final; or one that took
        // up the backlash after a re-alignment.
        drives_without_tags_ = 0;
        last_delta_theta_rad_ = wrapAngle(m.heading_rad - heading_before_drive_);
      } else {
        drives_without_tags_ = 0;
        last_delta_theta_rad_ = wrapAngle(m.heading_rad - heading_before_drive_);
        const TrimIteration& it =
            estimator_.addDrive(last_delta_theta_rad_, drive_left_angle_rad_);  // throws
        // What is left of the error: the undamped part of the correction, and a quarter of the step
        // for the model and the measurement (the deadband fit is still settling after the first
        // drives).
        if (!it.rejected) {
          ratio_error_ = std::max(0.002, std::abs(it.ratio_before / it.k_i - it.ratio_after) +
                                             0.25 * std::abs(it.step));
        }
        ++iteration_;
      }
      // Paper §3.4: drive back as far, with the ratio of the drive forward (the update counts from
      // the next drive), then go on. When fitting the deadband, every other drive back at another
      // speed (the first one included): each wheel's line gets a second duty, and the drives back
      // alone span two duties, so that a motor faster one way than the other does not bend it.
      {
        const bool other_speed = options_.compensate_deadband && back_drives_ % 2 == 0;
        ++back_drives_;
        const double back_mps = other_speed ? options_.back_speed_mps : options_.drive_speed_mps;
        const KinematicsParams& p = drive_params_;
        const double w = back_mps / p.radius;
        // Steered until the motor fit tells the directions apart (then its slopes per direction
        // drive back straight, and the drives back, unsteered, give it clean points), after a
        // forward drive long enough for its wheels' ratio (a tick is then at most 2 % of it):
        // from the duties that drive straight forward, with the correction the last steered drive
        // back at this speed ended with (the motors' difference between the directions, learned;
        // steady through the drive, so that the motor fit's mean duty is the duty the rate
        // answers).
        const double min_angle = 50 * 2 * M_PI / ticks_per_rev_;
        const double ratio = drive_right_angle_rad_ / drive_left_angle_rad_;
        const bool directions_told =
            fitter_.left().per_direction && fitter_.right().per_direction;
        steer_ratio_ = options_.back_steer_s > 0 && !directions_told &&
                               drive_left_angle_rad_ > min_angle &&
                               drive_right_angle_rad_ > min_angle && ratio > 0.5 && ratio < 2
                           ? ratio
                           : 0.0;
        steer_slot_ = other_speed ? 1 : 0;
        steer_wheel_radps_ = w;
        steer_integral_ = steer_carried_[steer_slot_] * 2 * options_.back_steer_s *
                          options_.back_steer_s * w;
        steer_last_s_ = now_s;
        const WheelDuties straight = speedsToDuties(p, {w, w});
        const WheelDuties d = steer_ratio_ > 0 ? straight : backwardDuties(straight);
        duties_ = {-d.left, -d.right};
        drive_sign_ = -1;
        // A steered drive back follows no arc (its correction settles as it goes): the
        // extrinsics take no motion from it.
        since_still_ = steer_ratio_ > 0 ? SinceStill::kNone : SinceStill::kBackward;
        motion_ = Motion::kDrive;
        drive_ = DriveRecord();
        drive_.duties = d;
        drive_.backward = true;
        drive_.start_s = now_s;
        drive_start_left_ = encoders_.rawLeft();
        drive_start_right_ = encoders_.rawRight();
        // As long as the forward drive was commanded, at the speed ratio: the same distance.
        // Beyond the paper: lengthened or shortened by the share of the forward drive's distance
        // the earlier cycles left the robot ahead of (or behind) where the iteration started, by
        // the encoders. A command's lag that differs between start and stop (a node behind the
        // simulator) otherwise makes the robot creep off the tag field over the cycles.
        const double creep = creep_m_ - drive_forward_m_;
        const double excess =
            std::copysign(std::max(0.0, std::abs(creep) - kCreepDeadzoneM), creep);
        const double correction =
            drive_forward_m_ > 0.05
                ? std::clamp(excess / drive_forward_m_, -kMaxCreepShare, kMaxCreepShare)
                : 0.0;
        startMotionClock(forward_s_ * drive_speed_mps_ / back_mps * (1 + correction));
        purpose_ = Purpose::kAfterBack;
      }
      return;
    case Purpose::kAfterForward:
    case Purpose::kAfterBack:
    case Purpose::kLeaveDrive:
      return;
  }
}

void WheelRun::startLeave(double now_s) {
  // Paper §5.1: aligned with the tags, which point towards the lane: drive straight until the last
  // tag has left the view, then a little further (the camera does not see the floor just ahead).
  startDrive(now_s, +1, options_.leave_speed_mps);
  since_still_ = SinceStill::kNone;
  motion_len_s_ = std::numeric_limits<double>::infinity();
  purpose_ = Purpose::kLeaveDrive;
  leave_start_left_ = encoders_.rawLeft();
  last_tag_seen_s_ = now_s;
  frames_without_tags_ = 0;
  leave_clear_ = false;
}

void WheelRun::steerLeave(double now_s) {
  const WheelDuties& straight = drive_.duties;
  if (now_s - leave_sighted_s_ > options_.leave_steer_max_age_s ||
      (options_.leave_lateral_gain_rad_per_m == 0 && options_.leave_heading_gain_per_s == 0)) {
    duties_ = straight;
    return;
  }
  // Heading towards the line, then along it: a turn rate (counter-clockwise) from the heading's
  // error, with each wheel kept turning forward.
  const KinematicsParams& p = drive_params_;
  const double limit = options_.leave_max_correction_rad;
  const double target_rad =
      std::clamp(-options_.leave_lateral_gain_rad_per_m * leave_lateral_m_, -limit, limit);
  const double v = options_.leave_speed_mps;
  const double max_rate = v / p.baseline;  // the slower wheel at half the speed
  const double rate = std::clamp(
      options_.leave_heading_gain_per_s * wrapAngle(target_rad - leave_heading_rad_), -max_rate,
      max_rate);
  duties_ = speedsToDuties(
      p, {(v - rate * p.baseline / 2) / p.radius, (v + rate * p.baseline / 2) / p.radius});
}

void WheelRun::onSettled(double now_s) {
  if (stage_ == WheelRunStage::kLeave) {
    stage_ = WheelRunStage::kDone;
    motion_ = Motion::kNone;
    return;
  }
  switch (purpose_) {
    case Purpose::kAlign: {
      // The step just made: pivoting on the left wheel, the right wheel's turn R·φ_r/L.
      const double phi = (encoders_.rawRight() - pulse_start_right_) * 2 * M_PI / ticks_per_rev_;
      const double turned =
          std::abs(options_.kinematics.radius * phi / options_.kinematics.baseline);
      if (pulse_by_ticks_) {
        const double past = std::abs(encoders_.rawRight() - pulse_start_right_) - pulse_stop_ticks_;
        pulse_overshoot_ticks_ =
            overshoot_measured_ ? 0.5 * (pulse_overshoot_ticks_ + past) : std::max(0.0, past);
        pulse_overshoot_ticks_ = std::max(0.0, pulse_overshoot_ticks_);
        overshoot_measured_ = true;
      }
      pulse_by_ticks_ = false;
      if (encoders_.rawRight() == pulse_start_right_) {
        turn_duty_boost_ += 0.02;  // the wheel did not move: the guessed deadband was too low
      }
      search_turned_rad_ += turned;
      startMeasure(Purpose::kAlign, now_s);
      return;
    }
    case Purpose::kAfterForward:
      drive_forward_m_ = driveDistanceM();
      creep_m_ += drive_forward_m_;
      drive_left_angle_rad_ = (encoders_.rawLeft() - drive_start_left_) * 2 * M_PI / ticks_per_rev_;
      drive_right_angle_rad_ =
          (encoders_.rawRight() - drive_start_right_) * 2 * M_PI / ticks_per_rev_;
      forward_s_ = drive_.end_s - drive_.start_s;
      recordDriveForFit();
      startMeasure(Purpose::kAfterDrive, now_s);
      return;
    case Purpose::kSpin:
      startMeasure(Purpose::kSpin, now_s);
      return;
    case Purpose::kAfterBack:
      creep_m_ += driveDistanceM();  // negative: a drive back
      recordDriveForFit();
      if (estimator_.converged() && motorFitPending()) {
        if (fit_cycles_ >= options_.max_fit_cycles) {
          fail("the motor fit found no deadband for the " + std::string(wheelsWithoutLine(fitter_.left(), fitter_.right())) +
               " after the trim converged and " + std::to_string(fit_cycles_) +
               " more drives forward and back (max_fit_cycles): its drives' rates did not lie on "
               "a line with a deadband between 0 and the largest offset (a wheel slipping, a "
               "drive's duties still settling); nothing written rather than the guesses");
          return;
        }
        // The trim converged before both wheels' lines formed: the guesses would be written as
        // the deadbands. More drives forward and back, for the fit alone.
        ++fit_cycles_;
        startMeasure(Purpose::kBeforeDrive, now_s);
      } else if (estimator_.converged() && options_.extrinsics_spins > 0 && !extrinsics_done_) {
        // Aligned with the tags first: the drives back retrace the forward drives and keep the
        // heading they had, and a robot turned away from the tag line sees fewer tags in the
        // extrinsics' stills.
        startAlign(WheelRunStage::kExtrinsics);
      } else if (estimator_.converged()) {
        startAlign(WheelRunStage::kLeave);
      } else {
        startMeasure(Purpose::kBeforeDrive, now_s);
      }
      return;
    default:
      startMeasure(Purpose::kBeforeDrive, now_s);
      return;
  }
}

WheelDuties WheelRun::update(double now_s) {
  if (stage_ == WheelRunStage::kFailed || stage_ == WheelRunStage::kDone) return {};
  if (!started_) {
    started_ = true;
    start_s_ = now_s;
  }
  last_now_s_ = now_s;
  if (stage_ == WheelRunStage::kWaitForData) {
    if (!have_frame_ && now_s - start_s_ > options_.camera_timeout_s) {
      fail("no camera frame within camera_timeout_s " + formatNumber(options_.camera_timeout_s, 3) +
           " s");
    }
    if (!encoders_.valid() && now_s - start_s_ > options_.encoder_timeout_s) {
      fail("no encoder reading within encoder_timeout_s " +
           formatNumber(options_.encoder_timeout_s, 3) + " s");
    }
    if (!have_frame_ || !encoders_.valid()) return {};
    startAlign(WheelRunStage::kIterate);
  }
  ++updates_without_frames_;
  ++updates_without_encoders_;
  if (updates_without_frames_ > kSilentUpdates &&
      now_s - std::max(last_frame_arrival_s_, measure_from_s_) > options_.camera_timeout_s &&
      (motion_ == Motion::kMeasure || stage_ == WheelRunStage::kLeave)) {
    fail("the camera went silent for more than camera_timeout_s " +
         formatNumber(options_.camera_timeout_s, 3) + " s");
  }
  if (updates_without_encoders_ > kSilentUpdates &&
      now_s - encoders_.stampS() > options_.encoder_timeout_s) {
    fail("the encoders went silent for more than encoder_timeout_s " +
         formatNumber(options_.encoder_timeout_s, 3) + " s");
  }
  if (now_s - start_s_ > options_.max_duration_s) {
    fail("the wheel stage took longer than max_duration_s " +
         formatNumber(options_.max_duration_s, 4) + " s");
  }
  if ((motion_ == Motion::kPulse || motion_ == Motion::kSpin || motion_ == Motion::kDrive) &&
      !motion_clock_started_) {
    motion_clock_started_ = true;
    motion_end_s_ = now_s + motion_len_s_;
    if (motion_ == Motion::kDrive) drive_.start_s = now_s;
  }
  switch (motion_) {
    case Motion::kPulse:
      if (now_s >= motion_end_s_ ||
          std::abs(encoders_.rawRight() - pulse_start_right_) >= pulse_stop_ticks_) {
        pulse_by_ticks_ = now_s < motion_end_s_;
        stopMotion(now_s);
      }
      break;
    case Motion::kSpin:
      if (now_s >= motion_end_s_ ||
          std::abs(encoders_.rawRight() - spin_start_right_) >= spin_ticks_)
        stopMotion(now_s);
      break;
    case Motion::kDrive:
      if (stage_ == WheelRunStage::kLeave) {
        const double r = options_.kinematics.radius * 2 * M_PI / ticks_per_rev_;
        const double driven = (encoders_.rawLeft() - leave_start_left_) * r;
        if (!leave_clear_ && now_s - last_tag_seen_s_ >= options_.leave_clear_s &&
            frames_without_tags_ >= options_.leave_clear_frames) {
          leave_clear_ = true;
          leave_clear_left_ = encoders_.rawLeft();
        }
        if (leave_clear_ &&
            (encoders_.rawLeft() - leave_clear_left_) * r >= options_.exit_extra_m) {
          stopMotion(now_s);
        } else if (!leave_clear_ && driven > options_.max_leave_m) {
          fail("still seeing tags after driving " + formatNumber(driven, 3) +
               " m out of the tag field (max_leave_m)");
        } else {
          steerLeave(now_s);
        }
      } else if (now_s >= motion_end_s_) {
        stopMotion(now_s);
        if (stage_ != WheelRunStage::kExtrinsics)
          purpose_ = drive_sign_ > 0 ? Purpose::kAfterForward : Purpose::kAfterBack;
      } else if (drive_sign_ < 0 && steer_ratio_ > 0) {
        steerBack(now_s);
      }
      break;
    case Motion::kSettle:
      if (settled(now_s)) onSettled(now_s);
      break;
    case Motion::kMeasure:
    case Motion::kNone:
      break;
  }
  return duties_;
}

double WheelRun::progress() const {
  switch (stage_) {
    case WheelRunStage::kWaitForData:
      return 0.0;
    case WheelRunStage::kAlign:
      if (after_align_ == WheelRunStage::kExtrinsics) return 0.8;
      return after_align_ == WheelRunStage::kLeave ? 0.85 : 0.05 + 0.05 * std::min(iteration_, 1);
    case WheelRunStage::kIterate:
      return 0.1 + 0.7 * std::min(1.0, iteration_ / 8.0);
    case WheelRunStage::kExtrinsics: {
      const int hops_per_pass = options_.extrinsics_drives + options_.extrinsics_drives_back;
      const int done = spins_done_ + extrinsics_pass_ * hops_per_pass + extrinsics_drives_done_;
      // Passes past extrinsics_passes (a mount refused so far) hold the progress below 0.85.
      const int passes = std::max(options_.extrinsics_passes, extrinsics_pass_ + 1);
      const int planned = options_.extrinsics_spins + passes * hops_per_pass;
      return 0.8 + 0.05 * done / std::max(1, planned);
    }
    case WheelRunStage::kLeave:
      return 0.9;
    default:
      return 1.0;
  }
}

std::string WheelRun::describe() const {
  std::string s = std::string(name(stage_));
  if (stage_ == WheelRunStage::kAlign) s += " step " + std::to_string(align_steps_);
  s += ", iteration " + std::to_string(iteration_) + ", k " + formatNumber(estimator_.ratio(), 6) +
       " (trim " +
       formatNumber(trimFromSpeedRatio(estimator_.ratio(), options_.kinematics.gain), 4) + ")";
  if (iteration_ > 0) s += ", last dtheta " + deg(last_delta_theta_rad_);
  if (fit_cycles_ > 0) s += ", motor fit drive " + std::to_string(fit_cycles_);
  if (std::isfinite(last_heading_rad_)) s += ", heading " + deg(last_heading_rad_);
  if (fitter_.left().valid && fitter_.right().valid) {
    s += ", deadband " + formatNumber(fitter_.left().offset, 4) + "/" +
         formatNumber(fitter_.right().offset, 4);
  }
  return s;
}

}  // namespace wheels
}  // namespace autocal
