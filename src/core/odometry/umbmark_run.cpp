// UMBmark driven by the robot (Borenstein & Feng 1996; paper 002 §1.2, §3.2); see umbmark_run.h.
#include "autocal/odometry/umbmark_run.h"

#include <algorithm>
#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/odometry/calibration_file.h"

namespace autocal {
namespace odometry {

namespace {
constexpr double kRateWindowS = 0.4;

const UmbmarkRunOptions& validated(const UmbmarkRunOptions& options) {
  options.validate();
  return options;
}
}  // namespace

const char* name(UmbmarkPhase phase) {
  switch (phase) {
    case UmbmarkPhase::kWait:
      return "wait";
    case UmbmarkPhase::kClockwise:
      return "umbmark_cw";
    case UmbmarkPhase::kCounterClockwise:
      return "umbmark_ccw";
    case UmbmarkPhase::kDone:
      return "done";
    case UmbmarkPhase::kFailed:
      return "failed";
  }
  return "?";
}

void UmbmarkRunOptions::validate() const {
  nominal.validate();
  umbmark().validate();
  EncoderDriveOptions::validate();
  checkConfig(side_m > 2 * nominal.wheelbase_m && side_m < 50, "side_m",
              "must be within (2 wheelbases, 50) [m]");
  checkConfig(runs_per_direction >= 1 && runs_per_direction <= 20, "runs_per_direction",
              "must be within [1, 20]");
  checkConfig(drive_rate_pulses_per_s > 0, "drive_rate_pulses_per_s", "must be > 0 [pulses/s]");
  checkConfig(turn_rate_pulses_per_s > 0, "turn_rate_pulses_per_s", "must be > 0 [pulses/s]");
  checkConfig(ramp_s > 0, "ramp_s", "must be > 0 [s]");
  checkConfig(heading_gain_duty_per_pulse >= 0, "heading_gain_duty_per_pulse", "must be >= 0");
  checkConfig(heading_integral_duty_per_pulse_s >= 0, "heading_integral_duty_per_pulse_s",
              "must be >= 0");
  checkConfig(cross_track_gain_per_m >= 0, "cross_track_gain_per_m", "must be >= 0 [1/m]");
  checkConfig(stop_lead_s >= 0 && stop_lead_s < 1, "stop_lead_s", "must be within [0, 1) [s]");
  checkConfig(max_return_error_fraction > 0 && max_return_error_fraction <= 4,
              "max_return_error_fraction", "must be within (0, 4]");
  checkConfig(max_duration_s >= 0, "max_duration_s", "must be >= 0 [s] (0: no limit)");
  checkConfig(error_timeout_s >= 0, "error_timeout_s", "must be >= 0 [s] (0: no limit)");
  checkConfig(run_pause_s >= 0, "run_pause_s", "must be >= 0 [s]");
  checkConfig(errors_file.empty() || errors_after_all, "errors_file",
              "needs errors_after_all (the file holds every square's error)");
}

std::string UmbmarkRunOptions::summary() const {
  return std::to_string(runs_per_direction) + " squares of " + formatNumber(side_m, 3) +
         " m each way (" + toString(expressions) + " expressions), return errors " +
         (errors_after_all ? "from " + errors_file + " after all squares"
                           : std::string("on ~return_error after each square"));
}

UmbmarkOptions UmbmarkRunOptions::umbmark() const {
  UmbmarkOptions o;
  o.side_m = side_m;
  o.wheelbase_m = nominal.wheelbase_m;
  o.expressions = expressions;
  return o;
}

UmbmarkRun::UmbmarkRun(const UmbmarkRunOptions& options)
    : options_(validated(options)), drive_(options, kMaxSettleS), odometry_(options.nominal) {}

void UmbmarkRun::fail(const std::string& why) {
  phase_ = UmbmarkPhase::kFailed;
  motion_ = Motion::kNone;
  duties_ = {};
  awaiting_error_ = false;
  failure_ = why;
  throw CalibrationError(why);
}

void UmbmarkRun::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                             int /*ticks_per_revolution*/, double /*now_s*/) {
  if (failed() || done()) return;
  EncoderTracker::Step step;
  const std::string jump = drive_.add(stamp_s, left_ticks, right_ticks, &step);
  if (!jump.empty()) fail(jump + "; the odometry of the square cannot be trusted");
  if (!step.accepted || step.first) return;
  // The square's odometry (the robot may be pushed while waiting for an error: only motion
  // during a run counts, and each run starts from zero).
  if (motion_ != Motion::kNone && motion_ != Motion::kPause)
    odometry_.addPulses(step.left_ticks, step.right_ticks);
  drive_.keepSample();
  drive_.forgetOlderThan(1.0);  // the wheel rates need the last kRateWindowS
}

double UmbmarkRun::wheelRate(int side) const { return drive_.rate(side, kRateWindowS); }

int UmbmarkRun::runInDirection() const {
  const int n = options_.runs_per_direction;
  return std::min(runs_done_, 2 * n - 1) % n + 1;
}

void UmbmarkRun::startRun(double now_s) {
  phase_ = runs_done_ < options_.runs_per_direction ? UmbmarkPhase::kClockwise
                                                    : UmbmarkPhase::kCounterClockwise;
  odometry_ = DeadReckoning(options_.nominal);
  leg_ = 0;
  run_start_s_ = now_s;
  startLeg(now_s);
  // The run's clock (and the helper's start pose) begins when its first duties go out.
}

void UmbmarkRun::startLeg(double now_s) {
  motion_ = Motion::kDrive;
  drive_.startMotion(now_s, drive_duty_ > 0 ? drive_duty_ : options_.start_duty);
}

void UmbmarkRun::startTurn(double now_s) {
  motion_ = Motion::kTurn;
  drive_.startMotion(now_s, options_.start_duty);
  for (int side = 0; side < 2; ++side) {
    if (turn_duty_[side] > 0) drive_.setDuty(side, turn_duty_[side]);
  }
}

void UmbmarkRun::stop(double now_s) {
  if (motion_ == Motion::kDrive) drive_duty_ = 0.5 * (drive_.duty(0) + drive_.duty(1));
  if (motion_ == Motion::kTurn) turn_duty_[0] = drive_.duty(0), turn_duty_[1] = drive_.duty(1);
  duties_ = {};
  motion_ = Motion::kSettle;
  drive_.stop(now_s);
}

void UmbmarkRun::onSettled(double now_s) {
  // After leg k comes turn k; after turn 3 the square is closed (the robot faces as it started).
  if (!was_turning_) {
    was_turning_ = true;
    startTurn(now_s);
    return;
  }
  was_turning_ = false;
  if (leg_ < 3) {
    ++leg_;
    startLeg(now_s);
    return;
  }
  computed_ends_.push_back(odometry_.pose());
  motion_ = Motion::kNone;
  awaiting_since_s_ = now_s;
  if (!options_.errors_after_all) {
    awaiting_error_ = true;
    return;
  }
  ++runs_done_;
  if (runs_done_ >= 2 * options_.runs_per_direction) {
    awaiting_all_ = true;
    return;
  }
  motion_ = Motion::kPause;
  pause_until_s_ = now_s + options_.run_pause_s;
}

void UmbmarkRun::checkError(const ReturnError& error, const std::string& which) {
  if (!std::isfinite(error.x_m) || !std::isfinite(error.y_m)) {
    throw InputError(which + ": a return error must be two finite numbers [m], got (" +
                     formatNumber(error.x_m) + ", " + formatNumber(error.y_m) + ")");
  }
  const double limit = options_.max_return_error_fraction * options_.side_m;
  if (std::hypot(error.x_m, error.y_m) > limit) {
    fail(which + ": the return error (" + formatNumber(error.x_m, 4) + ", " +
         formatNumber(error.y_m, 4) + ") m is larger than " + formatNumber(limit, 3) + " m (" +
         formatNumber(100 * options_.max_return_error_fraction, 3) +
         " % of the side): metres expected; a wrong measurement, a slipping wheel or a run cut "
         "short");
  }
}

void UmbmarkRun::setReturnErrors(const std::vector<ReturnError>& cw,
                                 const std::vector<ReturnError>& ccw) {
  if (!awaiting_all_) throw InputError("the UMBmark run is not waiting for all its return errors");
  const size_t n = static_cast<size_t>(options_.runs_per_direction);
  if (cw.size() != n || ccw.size() != n) {
    throw InputError("expected " + std::to_string(n) + " return errors in each direction (the " +
                     "squares driven), got " + std::to_string(cw.size()) + " cw and " +
                     std::to_string(ccw.size()) + " ccw");
  }
  for (size_t i = 0; i < n; ++i) checkError(cw[i], "cw[" + std::to_string(i) + "]");
  for (size_t i = 0; i < n; ++i) checkError(ccw[i], "ccw[" + std::to_string(i) + "]");
  awaiting_all_ = false;
  cw_ = cw, ccw_ = ccw;
  finish();
}

void UmbmarkRun::readErrorsFile(double now_s) {
  if (now_s - errors_file_read_s_ < 1.0) return;
  errors_file_read_s_ = now_s;
  std::vector<ReturnError> cw, ccw;
  try {
    loadUmbmarkErrors(options_.errors_file, &cw, &ccw);
  } catch (const Error& e) {
    errors_file_wait_ = e.what();  // not written yet, or half-written: read again
    return;
  }
  const size_t n = static_cast<size_t>(options_.runs_per_direction);
  if (cw.size() != n || ccw.size() != n) {
    errors_file_wait_ = "it holds " + std::to_string(cw.size()) + " cw and " +
                        std::to_string(ccw.size()) + " ccw errors, waiting for " +
                        std::to_string(n) + " of each";
    return;
  }
  setReturnErrors(cw, ccw);  // a wrong error fails the run
}

void UmbmarkRun::setReturnError(const ReturnError& error) {
  if (!awaiting_error_) throw InputError("no UMBmark run is waiting for its return error");
  checkError(error, std::string(name(phase_)) + " run " + std::to_string(runInDirection()));
  awaiting_error_ = false;
  (phase_ == UmbmarkPhase::kClockwise ? cw_ : ccw_).push_back(error);
  ++runs_done_;
  if (runs_done_ >= 2 * options_.runs_per_direction) {
    finish();
    return;
  }
  startRun(drive_.lastS());
}

void UmbmarkRun::finish() {
  try {
    result_ = computeUmbmark(cw_, ccw_, options_.umbmark());
    checkOdometryCalibration(toOdometryCalibration(result_, options_.umbmark(), "", ""));
  } catch (const Error& e) {
    fail(std::string("UMBmark: ") + e.what());
  }
  phase_ = UmbmarkPhase::kDone;
  motion_ = Motion::kNone;
  duties_ = {};
}

WheelDuties UmbmarkRun::update(double now_s) {
  if (done() || failed()) return {};
  double dt = 0;
  const std::string late = drive_.tick(now_s, motion_ != Motion::kNone, options_.max_duration_s,
                                       "UMBmark run", name(phase_), &dt);
  if (!late.empty()) fail(late);
  if (!drive_.encoders().valid()) return {};
  if (phase_ == UmbmarkPhase::kWait) startRun(now_s);
  if (awaiting_all_ && !options_.errors_file.empty()) readErrorsFile(now_s);
  if (done()) return {};
  if (awaiting_error_ || awaiting_all_) {
    if (options_.error_timeout_s > 0 && now_s - awaiting_since_s_ > options_.error_timeout_s) {
      fail(std::string("no return error given for ") +
           (awaiting_all_
                ? std::string("the squares")
                : name(phase_) + std::string(" run ") + std::to_string(runInDirection())) +
           " in " + formatNumber(options_.error_timeout_s, 3) + " s");
    }
    return {};
  }
  if (motion_ == Motion::kPause) {
    if (now_s < pause_until_s_) return duties_ = {};
    startRun(now_s);
  }
  if (motion_ == Motion::kSettle) {
    if (drive_.settled(now_s)) onSettled(now_s);
    if (motion_ != Motion::kDrive && motion_ != Motion::kTurn) return duties_ = {};
  }
  if (drive_.clock().start(now_s) && leg_ == 0 && motion_ == Motion::kDrive) run_start_s_ = now_s;
  const double moving_s = drive_.clock().elapsedS(now_s);
  const DiffDriveParams& n = options_.nominal;
  const double c_mean = 0.5 * (n.left_m_per_pulse + n.right_m_per_pulse);
  const Pose2D& p = odometry_.pose();
  const double s = turnSign();
  // The square of umbmark.h in the run's frame: corner k at the end of leg k − 1, leg k heading
  // s·k·π/2 (clockwise turns right).
  const double heading = s * leg_ * M_PI / 2;
  const double ux = std::cos(heading), uy = std::sin(heading);
  double cx = 0, cy = 0;
  for (int k = 0; k < leg_; ++k) {
    cx += options_.side_m * std::cos(s * k * M_PI / 2);
    cy += options_.side_m * std::sin(s * k * M_PI / 2);
  }

  auto checkStall = [&](int side) {
    const std::string stall = drive_.stall(side, now_s);
    if (!stall.empty()) {
      fail(std::string(name(phase_)) + " run " + std::to_string(runInDirection()) + ", leg " +
           std::to_string(leg_ + 1) + ": " + stall);
    }
  };

  if (motion_ == Motion::kTurn) {
    // A 90° turn in place on the odometry's heading: both wheels at the turn rate, opposite.
    const double target = heading + s * M_PI / 2;
    const double remaining = s * wrapAngle(target - p.yaw_rad);
    const double yaw_rate = 2 * options_.turn_rate_pulses_per_s * c_mean / n.wheelbase_m;
    if (remaining <= yaw_rate * options_.stop_lead_s) {
      stop(now_s);
      return duties_;
    }
    drive_.follow(0, wheelRate(0), options_.turn_rate_pulses_per_s, dt);
    drive_.follow(1, wheelRate(1), options_.turn_rate_pulses_per_s, dt);
    checkStall(0);
    checkStall(1);
    duties_ = {-s * drive_.duty(0), s * drive_.duty(1)};
    return duties_;
  }

  // A leg: L along the leg's line by odometry, the heading held on the line (cross-track).
  const double along = (p.x_m - cx) * ux + (p.y_m - cy) * uy;
  const double offset = -(p.x_m - cx) * uy + (p.y_m - cy) * ux;  // left of the line: > 0
  const double rate_target =
      options_.turn_rate_pulses_per_s +
      std::clamp(moving_s / options_.ramp_s, 0.0, 1.0) *
          (options_.drive_rate_pulses_per_s - options_.turn_rate_pulses_per_s);
  const double speed_m_s = rate_target * c_mean;
  if (along >= options_.side_m - speed_m_s * options_.stop_lead_s) {
    stop(now_s);
    return duties_;
  }
  const double mean_rate = 0.5 * (wheelRate(0) + wheelRate(1));
  drive_.follow(0, mean_rate, rate_target, dt);
  drive_.setDuty(1, drive_.duty(0));
  checkStall(0);
  checkStall(1);
  const double wanted = heading - std::atan(options_.cross_track_gain_per_m * offset);
  // The heading error as the pulse difference that turns it away (e·b/c̄).
  const double error_pulses = wrapAngle(wanted - p.yaw_rad) * n.wheelbase_m / c_mean;
  heading_integral_ += error_pulses * dt;
  const double steer = options_.heading_gain_duty_per_pulse * error_pulses +
                       options_.heading_integral_duty_per_pulse_s * heading_integral_;
  duties_ = {std::clamp(drive_.duty(0) - 0.5 * steer, 0.0, options_.max_duty),
             std::clamp(drive_.duty(0) + 0.5 * steer, 0.0, options_.max_duty)};
  return duties_;
}

double UmbmarkRun::progress() const {
  if (done()) return 1.0;
  const double runs = 2.0 * options_.runs_per_direction;
  double part = 0;
  if (phase_ == UmbmarkPhase::kClockwise || phase_ == UmbmarkPhase::kCounterClockwise) {
    if (awaiting_error_) {
      part = 1.0;  // the run is counted once its error is given
    } else if (!awaiting_all_ && motion_ != Motion::kPause) {
      part = (leg_ + (was_turning_ ? 0.75 : 0.0)) / 4.0;
    }
  }
  return std::min(1.0, (runs_done_ + part) / runs);
}

std::string UmbmarkRun::describe() const {
  std::string s = name(phase_);
  if (phase_ == UmbmarkPhase::kClockwise || phase_ == UmbmarkPhase::kCounterClockwise) {
    s += " run " + std::to_string(runInDirection()) + "/" +
         std::to_string(options_.runs_per_direction);
    if (awaiting_all_) {
      s += ", all " + std::to_string(2 * options_.runs_per_direction) +
           " squares driven, waiting for their return errors";
      if (!options_.errors_file.empty())
        s += " in " + options_.errors_file +
             (errors_file_wait_.empty() ? "" : " (" + errors_file_wait_ + ")");
    } else if (motion_ == Motion::kPause) {
      s += " driven (computed end " + formatNumber(computedPose().x_m, 3) + ", " +
           formatNumber(computedPose().y_m, 3) + " m), pausing before the next";
    } else if (awaiting_error_) {
      s += ", waiting for its return error (computed end " + formatNumber(computedPose().x_m, 3) +
           ", " + formatNumber(computedPose().y_m, 3) + " m)";
    } else {
      s += std::string(was_turning_ ? ", turn " : ", leg ") + std::to_string(leg_ + 1) + "/4";
    }
  }
  const auto last = [](const std::vector<ReturnError>& v) {
    return v.empty() ? std::string()
                     : " (" + formatNumber(v.back().x_m, 3) + ", " + formatNumber(v.back().y_m, 3) +
                           ") m";
  };
  if (!cw_.empty()) s += ", cw errors " + std::to_string(cw_.size()) + last(cw_);
  if (!ccw_.empty()) s += ", ccw errors " + std::to_string(ccw_.size()) + last(ccw_);
  if (done()) {
    s += ", Ed " + formatNumber(result_.Ed, 6) + ", Eb " + formatNumber(result_.Eb, 6) +
         ", E_max,syst " + formatNumber(1000 * result_.E_max_syst_m, 4) + " mm";
  }
  if (failed()) s += ": " + failure_;
  return s;
}

StageStatus UmbmarkRun::status() const {
  StageStatus s;
  s.step = name(phase_);
  const int squares = static_cast<int>(cw_.size() + ccw_.size() + computed_ends_.size());
  // A helper or a person acts on each new square, leg and wait for return errors.
  s.key = std::to_string(runInDirection()) + "/" + std::to_string(leg()) + "/" +
          std::to_string(needsReturnError()) + "/" + std::to_string(needsAllReturnErrors()) + "/" +
          std::to_string(squares);
  s.progress = progress();
  s.text = describe();
  s.figures = {{"run", static_cast<double>(runInDirection())},
               {"leg", static_cast<double>(leg())},
               {"squares_driven", static_cast<double>(computed_ends_.size())},
               {"awaiting_error", needsReturnError() ? 1.0 : 0.0},
               {"awaiting_errors_file", needsAllReturnErrors() ? 1.0 : 0.0},
               {"run_start_s", runStartS()},
               {"computed_x_m", computedPose().x_m},
               {"computed_y_m", computedPose().y_m},
               {"elapsed_s", elapsedS()}};
  return s;
}

StageResult UmbmarkRun::finish(const StageOutput& output) {
  const OdometryCalibration c =
      toOdometryCalibration(result_, options_.umbmark(), output.veh, options_.errors_source);
  StageResult r;
  r.file = odometryCalibrationPath(output.calibration_root, output.veh);
  writeOdometryCalibration(r.file, c);  // the quality gate first; throws on failure
  r.figures = {{"Ed", c.Ed},
               {"Eb", c.Eb},
               {"wheelbase_m", c.wheelbase_m},
               {"left_pulse_factor", c.left_pulse_factor},
               {"right_pulse_factor", c.right_pulse_factor},
               {"E_max_syst_m", result_.E_max_syst_m},
               {"runs_cw", static_cast<double>(result_.runs_cw)},
               {"runs_ccw", static_cast<double>(result_.runs_ccw)},
               {"elapsed_s", elapsedS()}};
  r.log = "UMBmark (" + c.expressions + " expressions) Ed " + formatNumber(c.Ed, 5) + ", Eb " +
          formatNumber(c.Eb, 5) + " (wheelbase " + formatNumber(c.wheelbase_m, 5) + " m), c_L x" +
          formatNumber(c.left_pulse_factor, 5) + ", c_R x" + formatNumber(c.right_pulse_factor, 5) +
          ", E_max,syst " + formatNumber(1000 * result_.E_max_syst_m, 3) + " mm, " +
          formatNumber(elapsedS(), 4) + " s";
  return r;
}

}  // namespace odometry
}  // namespace autocal
