// The camera stage's step loop (paper 000 §3.2): pulse, stop, settle, grab, detect, decide.
#include "autocal/camera/sweep_run.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "autocal/camera/calibration_files.h"
#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/parallel.h"

namespace autocal {
namespace camera {

void SweepRunOptions::validate() const {
  sweep.validate();
  probe.validate();
  checkConfig(std::isfinite(min_duty) && min_duty > 0 && min_duty < 1, "min_duty",
              "must be in (0, 1)");
  checkConfig(std::isfinite(target_step_rad) && target_step_rad >= 0 && target_step_rad < 1.0,
              "target_step_rad", "must be in [0, 1) rad (0 = minimum duty steps)");
  checkConfig(std::isfinite(max_step_duty) && max_step_duty > 0 && max_step_duty <= 1,
              "max_step_duty", "must be in (0, 1]");
  checkConfig(std::isfinite(nominal_wheel_radius_m) && nominal_wheel_radius_m > 0,
              "nominal_wheel_radius_m", "must be > 0");
  checkConfig(std::isfinite(nominal_wheelbase_m) && nominal_wheelbase_m > 0, "nominal_wheelbase_m",
              "must be > 0");
  checkConfig(std::isfinite(still_s) && still_s >= 0, "still_s", "must be >= 0");
  stillness.validate();
  checkConfig(std::isfinite(max_still_wait_s) && max_still_wait_s >= 0, "max_still_wait_s",
              "must be >= 0 [s]");
  checkConfig(std::isfinite(camera_timeout_s) && camera_timeout_s > 0, "camera_timeout_s",
              "must be > 0");
  checkConfig(std::isfinite(encoder_timeout_s) && encoder_timeout_s > 0, "encoder_timeout_s",
              "must be > 0");
  checkConfig(std::isfinite(max_duration_s) && max_duration_s > 0, "max_duration_s", "must be > 0");
  for (double g : coverage_goal)
    checkConfig(std::isfinite(g) && g <= 1.0, "coverage_goal",
                "each spread must be <= 1 (negative: the config's)");
  checkConfig(min_views >= 1, "min_views", "must be >= 1");
  checkConfig(refine_rounds >= 0, "refine_rounds", "must be >= 0");
  checkConfig(std::isfinite(refine_spread_rad) && refine_spread_rad >= 0 && refine_spread_rad < 1,
              "refine_spread_rad", "must be in [0, 1) rad");
  checkConfig(std::isfinite(refine_tolerance_rad) && refine_tolerance_rad > 0 &&
                  refine_tolerance_rad < 0.5,
              "refine_tolerance_rad", "must be in (0, 0.5) rad");
  checkConfig(refine_max_steps >= 1, "refine_max_steps", "must be >= 1");
  checkConfig(std::isfinite(refine_max_s) && refine_max_s > 0, "refine_max_s", "must be > 0");
}

const char* name(SweepRunStage stage) {
  switch (stage) {
    case SweepRunStage::kWaitForData:
      return "wait";
    case SweepRunStage::kProbe:
      return "probe";
    case SweepRunStage::kSweep:
      return "collect";
    case SweepRunStage::kRefine:
      return "refine";
    case SweepRunStage::kJudge:
    case SweepRunStage::kSwept:
      return "calibrate";
    case SweepRunStage::kFailed:
      return "failed";
  }
  return "?";
}

namespace {

const SweepRunOptions& validated(const SweepRunOptions& o) {
  o.validate();
  return o;
}

}  // namespace

CameraCalibrationConfig sweepCameraConfig(CameraCalibrationConfig c, const SweepRunOptions& o) {
  c.validate();
  for (size_t i = 0; i < o.coverage_goal.size(); ++i) {
    if (o.coverage_goal[i] >= 0) c.selection.goal_spread[i] = o.coverage_goal[i];
  }
  c.selection.min_views = o.min_views;
  c.selection.keep_sharp_views = o.calibrate_on_sharp_views;
  c.validate();
  return c;
}

SweepRun::SweepRun(const SweepRunOptions& options, const CameraCalibrationConfig& camera)
    : options_(validated(options)),
      camera_(sweepCameraConfig(camera, options_)),
      controller_(options.sweep),
      probe_(options.probe),
      collector_(camera_.board, camera_.detector, camera_.selection),
      stillness_(options_.stillness) {
  duty_above_min_ = std::max(options_.sweep.step_duty_margin, 0.03);
}

void SweepRun::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                           int ticks_per_revolution, double now_s) {
  if (ticks_per_revolution <= 0)
    throw InputError("encoder resolution " + std::to_string(ticks_per_revolution) +
                     ": must be > 0 ticks per revolution");
  const EncoderTracker::Step step = encoders_.add(stamp_s, left_ticks, right_ticks);
  if (!step.accepted) return;
  if (step.first) {
    obs_left_ = probe_start_left_ = left_ticks;
    obs_right_ = probe_start_right_ = right_ticks;
  }
  encoder_arrival_s_ = std::max(encoder_arrival_s_, now_s);
  updates_without_encoders_ = 0;
  ticks_per_rev_ = ticks_per_revolution;
}

void SweepRun::noteEncodersArrived(double now_s) {
  if (encoders_.valid()) encoder_arrival_s_ = std::max(encoder_arrival_s_, now_s);
  updates_without_encoders_ = 0;
}

void SweepRun::noteFrameArrived(double now_s) {
  have_frame_ = true;
  frame_arrival_s_ = std::max(frame_arrival_s_, now_s);
  updates_without_frames_ = 0;
}

bool SweepRun::settled(double now_s) const {
  const double settle_s =
      stage_ == SweepRunStage::kProbe ? options_.probe.settle_s : options_.sweep.settle_s;
  return SettleRule{settle_s, options_.still_s, options_.sweep.max_settle_s}.settled(stop_s_, now_s,
                                                                                     encoders_);
}

bool SweepRun::wantsFrame(double stamp_s) const {
  return (stage_ == SweepRunStage::kSweep ||
          (stage_ == SweepRunStage::kRefine && refine_grab_)) &&
         step_ == Step::kSettle && !pending_decision_ && settled_at_s_ >= 0 &&
         stamp_s >= settled_at_s_;
}

double SweepRun::headingChangeSinceObservation() {
  const double m_per_tick = 2 * M_PI * options_.nominal_wheel_radius_m / ticks_per_rev_;
  const double turned = ((encoders_.rawRight() - obs_right_) - (encoders_.rawLeft() - obs_left_)) *
                        m_per_tick / options_.nominal_wheelbase_m;
  obs_left_ = encoders_.rawLeft();
  obs_right_ = encoders_.rawRight();
  return turned;
}

void SweepRun::settleAt(double now_s) {
  settled_at_s_ = now_s;
  stillness_.reset();
}

bool SweepRun::addFrame(double stamp_s, const cv::Mat& image, const std::string& source) {
  if (!wantsFrame(stamp_s)) return false;
  if (!stillness_.add(stamp_s, image)) {
    if (stamp_s < settled_at_s_ + options_.max_still_wait_s) return false;
    ++views_not_seen_still_;
  }
  const int frame_index = collector_.frames();
  const size_t sharp_before = collector_.sharpViews().size();
  FrameResult frame = collector_.addFrame(image, source);
  SweepObservation obs;
  for (const ViewDecision& d : frame.decisions)
    obs.boards_x.push_back(std::min(1.0, std::max(0.0, d.params.x)));
  const bool sharp_seen = collector_.sharpViews().size() > sharp_before;
  if (frame.any_kept() || sharp_seen) frames_[frame_index] = toGray(image);
  const double turned = headingChangeSinceObservation();
  heading_rad_ += first_observation_ ? 0.0 : turned;
  frame_heading_[frame_index] = heading_rad_;
  if (stage_ == SweepRunStage::kRefine) {  // a view where the projection is least sure
    last_frame_.stamp_s = stamp_s;
    last_frame_.frame = std::move(frame);
    last_frame_.decision = SweepDecision{};
    last_frame_.decision.reason = "more views";
    pending_decision_ = true;
    return true;
  }
  obs.view_kept = frame.any_kept();
  obs.coverage_sufficient = collector_.coverage().sufficient;
  obs.turned_rad = first_observation_ ? 0.0 : turned;
  // Steps toward target_step_rad: the wheel speed grows about linearly with the duty above the
  // deadband, so the duty above the minimum is scaled by the ratio (bounded per step).
  if (!first_observation_ && options_.target_step_rad > 0 && last_was_turn_) {
    const double ratio = options_.target_step_rad / std::max(std::abs(turned), 1e-3);
    duty_above_min_ *= std::min(2.0, std::max(0.5, ratio));
    duty_above_min_ = std::max(options_.sweep.step_duty_margin,
                               std::min(duty_above_min_, options_.max_step_duty));
  }
  first_observation_ = false;
  last_frame_.stamp_s = stamp_s;
  last_frame_.frame = std::move(frame);
  last_frame_.decision = controller_.decide(obs);
  if (controller_.pass() != leg_) {  // a leg (a turn from one extreme board to the other) ended
    leg_arc_rad_ = std::max(leg_arc_rad_, std::abs(controller_.headingRad() - leg_start_rad_));
    leg_start_rad_ = controller_.headingRad();
    leg_ = controller_.pass();
  }
  pending_decision_ = true;
  return true;
}

const std::vector<CalibrationView>& SweepRun::calibrationViews() const {
  return collector_.calibrationViews();
}

MinDutyResult SweepRun::minDuty() const {
  if (options_.probe_min_duty) return probe_.result();
  MinDutyResult r;
  r.left_forward = r.left_backward = r.right_forward = r.right_backward = options_.min_duty;
  return r;
}

void SweepRun::fail(const std::string& reason) {
  stage_ = SweepRunStage::kFailed;
  throw CalibrationError(reason);
}

void SweepRun::failWithoutUsableFrame(double now_s) {
  // Waiting for a frame taken after settled_at_s_. Frames that keep coming but cannot be used
  // (undecodable, another size: the caller drops them) are a silent camera too.
  if (now_s - settled_at_s_ > options_.camera_timeout_s)
    fail("no usable camera frame for " + formatNumber(now_s - settled_at_s_, 3) +
         " s after the robot stopped (frames arrive, but none could be used)");
}

void SweepRun::startPulse(double now_s, const WheelDuties& duties, double length_s) {
  duties_ = duties;
  step_ = Step::kPulse;
  pulse_end_s_ = now_s + length_s;
  settled_at_s_ = -1;
}

WheelDuties SweepRun::update(double now_s) {
  const WheelDuties stop{0, 0};
  if (stage_ == SweepRunStage::kFailed || stage_ == SweepRunStage::kSwept) return stop;
  if (stage_ == SweepRunStage::kJudge) {
    judgeViews();
    return stop;
  }
  if (!have_first_update_) {
    have_first_update_ = true;
    first_update_s_ = now_s;
  }
  last_now_s_ = std::max(last_now_s_, now_s);

  if (stage_ == SweepRunStage::kWaitForData) {
    if (!have_frame_ && now_s - first_update_s_ > options_.camera_timeout_s)
      fail("no camera frame in " + formatNumber(options_.camera_timeout_s, 3) +
           " s: is the camera running (camera_node/image)?");
    if (!encoders_.valid() && now_s - first_update_s_ > options_.encoder_timeout_s)
      fail("no encoder reading of both wheels in " + formatNumber(options_.encoder_timeout_s, 3) +
           " s: are the wheel encoders running (left/right_wheel_encoder_node/tick)?");
    if (!have_frame_ || !encoders_.valid()) return stop;
    started_ = true;
    start_s_ = now_s;
    stage_ = options_.probe_min_duty ? SweepRunStage::kProbe : SweepRunStage::kSweep;
    step_ = Step::kSettle;
    stop_s_ = now_s;
    settled_at_s_ = -1;
  }

  // Silence is a time without messages over several updates in a row: a node that was not
  // scheduled for a while (the simulator runs on at real_time_factor 0) sees one long gap, and
  // then the messages that came meanwhile.
  ++updates_without_frames_;
  ++updates_without_encoders_;
  if (now_s - frame_arrival_s_ > options_.camera_timeout_s &&
      updates_without_frames_ > kSilentUpdates)
    fail("the camera has been silent for " + formatNumber(now_s - frame_arrival_s_, 3) +
         " s (camera_timeout_s " + formatNumber(options_.camera_timeout_s, 3) + ")");
  if (now_s - encoder_arrival_s_ > options_.encoder_timeout_s &&
      updates_without_encoders_ > kSilentUpdates)
    fail("the encoders have been silent for " + formatNumber(now_s - encoder_arrival_s_, 3) +
         " s (encoder_timeout_s " + formatNumber(options_.encoder_timeout_s, 3) + ")");
  if (now_s - start_s_ > options_.max_duration_s)
    fail("the camera stage took longer than max_duration_s " +
         formatNumber(options_.max_duration_s, 3) + " s (" + controller_.describe() + ")");

  if (step_ == Step::kPulse) {
    if (now_s < pulse_end_s_) return duties_;
    step_ = Step::kSettle;
    stop_s_ = now_s;
    settled_at_s_ = -1;
    duties_ = stop;
    return stop;
  }

  // Settling (or waiting for the settled frame).
  if (settled_at_s_ < 0) {
    if (!settled(now_s)) return stop;
    settleAt(now_s);
  }
  if (stage_ == SweepRunStage::kRefine) return refineStep(now_s);
  if (stage_ == SweepRunStage::kProbe) {
    const WheelCommand probed = probe_.command();
    const int moved = probed.wheel == Wheel::kLeft ? encoders_.rawLeft() - probe_start_left_
                                                   : encoders_.rawRight() - probe_start_right_;
    if (probe_pulsed_) probe_.report(moved, false);  // signed, + = forward
    if (probe_.failed()) fail("minimum duty probe: " + probe_.failure());
    if (probe_.finished()) {
      stage_ = SweepRunStage::kSweep;
      stop_s_ = now_s;
      settled_at_s_ = -1;
      return stop;
    }
    probe_start_left_ = encoders_.rawLeft();
    probe_start_right_ = encoders_.rawRight();
    probe_pulsed_ = true;
    startPulse(now_s, probe_.pulse(), options_.probe.pulse_s);
    return duties_;
  }

  if (!pending_decision_) {
    failWithoutUsableFrame(now_s);
    return stop;
  }
  pending_decision_ = false;
  const SweepDecision& decision = last_frame_.decision;
  if (decision.action == SweepAction::kFailed) fail("sweep: " + decision.reason);
  if (decision.action == SweepAction::kDone) {
    stage_ = SweepRunStage::kJudge;
    return stop;
  }
  const WheelCommand cmd = turnCommand(decision.direction, options_.sweep.pivot);
  const double duty = std::min(options_.max_step_duty, minDuty().forCommand(cmd) + duty_above_min_);
  last_was_turn_ = true;
  startPulse(now_s, toDuties(cmd, duty), options_.sweep.step_duration_s);
  return duties_;
}

std::vector<std::vector<cv::Point2f>> cornersToCalibrate(const std::vector<CalibrationView>& views,
                                                         const cv::Size& image_size,
                                                         const CameraCalibrationConfig& camera) {
  std::vector<std::vector<cv::Point2f>> corners;
  for (const CalibrationView& v : views) corners.push_back(v.corners);
  const bool kept_pixels = std::any_of(views.begin(), views.end(), [](const CalibrationView& v) {
    return !v.patch.gray.empty();
  });
  if (!camera.detector.refine_through_lens || !kept_pixels) return corners;
  // The listed lens model that explains the corners best: the lens only has to be right where
  // the corners are.
  std::vector<DistortionModel> models{camera.calibration.model};
  for (const DistortionModel m : camera.calibration.fallback_models) models.push_back(m);
  std::vector<std::optional<CalibrationResult>> fits(models.size());
  forEachIndex(models.size(), camera.calibration.threads, [&](size_t k) {
    CalibrationOptions o = camera.calibration;
    o.model = models[k];
    o.judge_whole_image = false;
    try {
      fits[k] = calibrate(corners, image_size, camera.board, o);
    } catch (const CalibrationError&) {
      if (k == 0) throw;  // the views themselves cannot determine a model
    }
  });
  std::optional<CalibrationResult> first;
  for (std::optional<CalibrationResult>& r : fits)
    if (r && (!first || r->all_corners_rms_px < first->all_corners_rms_px)) first = std::move(r);
  const CameraIntrinsics& lens = first->intrinsics;
  // A fisheye lens's corners are left as detected: over 20 drawn fisheye robots the refinement
  // changed the whole-image error by noise only (median 0.116 px, 0.112 with it), and a strong
  // fisheye's sweep went 2.9 px off at the image's corner with it, 8 times its uncertainty.
  if (lens.distortion_model == DistortionModel::kEquidistant) return corners;
  for (size_t i = 0; i < views.size(); ++i)
    corners[i] = refineThroughLens(views[i].patch, camera.board, corners[i], lens, camera.detector);
  return corners;
}

ModelChoice chooseSweepModel(const ViewCollector& collector, const CameraCalibrationConfig& camera) {
  if (collector.calibrationViews().empty())
    throw CalibrationError("no usable view of a " + camera.board.describe() + " board in " +
                           std::to_string(collector.frames()) + " frames");
  const std::vector<std::vector<cv::Point2f>> corners =
      cornersToCalibrate(collector.calibrationViews(), collector.imageSize(), camera);
  return calibrateChoosingModel(corners, collector.imageSize(), camera.board, camera.calibration,
                                camera.quality_gate);
}

CalibrationResult passedOrThrow(ModelChoice choice, const std::string& after) {
  if (!choice.passed) {
    throw CalibrationError(std::string("the result fails the quality gate") +
                           (choice.refused.size() > 1 ? " with every lens model tried" : "") +
                           after + ", nothing written: " + choice.refusals("; "));
  }
  return std::move(choice.result);
}

CalibrationResult calibrateSweepViews(const ViewCollector& collector,
                                      const CameraCalibrationConfig& camera) {
  return passedOrThrow(chooseSweepModel(collector, camera));
}

CalibrationResult SweepRun::calibrate() const {
  if (!swept()) throw CalibrationError("calibrate() before the sweep ended");
  if (choice_ && choice_->passed) return choice_->result;
  return calibrateSweepViews(collector_, camera_);
}

void SweepRun::judgeViews() {
  try {
    choice_ = chooseSweepModel(collector_, camera_);
  } catch (const CalibrationError& e) {
    fail(e.what());
  }
  if (choice_->passed) {
    stage_ = SweepRunStage::kSwept;
    return;
  }
  if (refine_round_ == 0) {
    sweep_refusal_ = choice_->refusals("; ");
    refine_views_before_ = static_cast<int>(calibrationViews().size());
  }
  // The rounds' budget counts their turning and views, not the judging: a fit of every lens model
  // may take a small computer minutes while the robot stands still.
  const bool out_of_time = refine_spent_s_ > options_.refine_max_s;
  if (refine_round_ < options_.refine_rounds && !out_of_time) {
    targets_ = viewTargets(choice_->result.uncertainty, choice_->result.intrinsics,
                           calibrationViews(), frame_heading_, heading_rad_);
  }
  if (refine_round_ >= options_.refine_rounds || out_of_time || targets_.empty()) {
    std::string after;
    if (refine_round_ > 0) {
      after = " after " + std::to_string(refine_round_) + " round" +
              (refine_round_ > 1 ? "s" : "") + " of more views where the projection was least sure (" +
              std::to_string(static_cast<int>(calibrationViews().size()) - refine_views_before_) +
              " views more" +
              (out_of_time ? "; refine_max_s " + formatNumber(options_.refine_max_s, 3) + " s spent"
                           : "") +
              ")";
    }
    try {
      passedOrThrow(std::move(*choice_), after);
    } catch (const CalibrationError& e) {
      fail(e.what());
    }
  }
  // Each target's heading and refine_spread_rad either side, visited in one turn from the end
  // nearer the robot's heading.
  refine_headings_.clear();
  for (const ViewTarget& t : targets_)
    for (const double d : {-options_.refine_spread_rad, 0.0, options_.refine_spread_rad})
      refine_headings_.push_back(t.heading_rad + d);
  std::sort(refine_headings_.begin(), refine_headings_.end());
  if (std::abs(heading_rad_ - refine_headings_.back()) <
      std::abs(heading_rad_ - refine_headings_.front()))
    std::reverse(refine_headings_.begin(), refine_headings_.end());
  refine_round_start_s_ = -1;
  ++refine_round_;
  refine_next_ = 0;
  refine_steps_ = 0;
  refine_last_remaining_ = 0;
  refine_grab_ = false;
  stage_ = SweepRunStage::kRefine;
}

WheelDuties SweepRun::refineStep(double now_s) {
  const WheelDuties stop{0, 0};
  heading_rad_ += headingChangeSinceObservation();
  if (refine_grab_) {
    if (!pending_decision_) {
      failWithoutUsableFrame(now_s);
      return stop;
    }
    pending_decision_ = false;
    refine_grab_ = false;
    ++refine_next_;
    refine_steps_ = 0;
    refine_last_remaining_ = 0;
  }
  if (refine_round_start_s_ < 0) refine_round_start_s_ = now_s;
  const double spent_s = refine_spent_s_ + (now_s - refine_round_start_s_);
  if (refine_next_ >= refine_headings_.size() || spent_s > options_.refine_max_s) {
    refine_spent_s_ = spent_s;
    stage_ = SweepRunStage::kJudge;
    return stop;
  }
  const double remaining = refine_headings_[refine_next_] - heading_rad_;
  const bool crossed = refine_steps_ > 0 && remaining * refine_last_remaining_ < 0;
  if (std::abs(remaining) <= options_.refine_tolerance_rad || crossed ||
      refine_steps_ >= options_.refine_max_steps) {
    // The next frame from now: the robot stood still since it settled, but a judgement may have
    // taken longer than camera_timeout_s since then.
    refine_grab_ = true;
    settleAt(std::max(settled_at_s_, now_s));
    return stop;
  }
  refine_last_remaining_ = remaining;
  ++refine_steps_;
  const WheelCommand cmd =
      turnCommand(remaining > 0 ? TurnDirection::kCcw : TurnDirection::kCw, options_.sweep.pivot);
  const double duty = std::min(options_.max_step_duty, minDuty().forCommand(cmd) + duty_above_min_);
  // A step turns about target_step_rad: shorter near the heading (not below half, which may not
  // move a wheel that needs a push to start).
  const double share =
      options_.target_step_rad > 0 ? std::abs(remaining) / options_.target_step_rad : 1.0;
  startPulse(now_s, toDuties(cmd, duty),
             options_.sweep.step_duration_s * std::max(0.5, std::min(1.0, share)));
  return duties_;
}

double SweepRun::progress() const {
  switch (stage_) {
    case SweepRunStage::kWaitForData:
      return 0;
    case SweepRunStage::kProbe:
      // The probe of the four wheel directions takes about as long as the sweep.
      return kProbeShare * probe_.probed() / 4.0;
    case SweepRunStage::kSweep: {
      // The sweep ends when the coverage suffices, in its second or third leg (the first legs
      // count the boards). The coverage (the worst of its measures and the views against
      // min_views) rises in bursts while boards are in view; the legs turned (each by its share
      // of the widest leg so far, half a turn before one ended) rise with the turning: the mean of
      // the two keeps pace with the sweep.
      const Coverage c = collector_.coverage();
      double coverage = std::min(1.0, static_cast<double>(c.views) / options_.min_views);
      for (double p : c.progress) coverage = std::min(coverage, p);
      const double arc_rad = leg_arc_rad_ > 0 ? leg_arc_rad_ : kFirstLegArcRad;
      const double within =
          std::min(0.9, std::abs(controller_.headingRad() - leg_start_rad_) / arc_rad);
      const double legs = std::min(1.0, (leg_ + within) / kExpectedLegs);
      return kProbeShare + (0.95 - kProbeShare) * 0.5 * (coverage + legs);
    }
    case SweepRunStage::kRefine: {
      const double round =
          refine_headings_.empty()
              ? 0.0
              : static_cast<double>(refine_next_) / static_cast<double>(refine_headings_.size());
      return 0.9 + 0.05 * std::min(1.0, (refine_round_ - 1 + round) /
                                             std::max(1, options_.refine_rounds));
    }
    case SweepRunStage::kJudge:
    case SweepRunStage::kSwept:
    case SweepRunStage::kFailed:
      return 0.95;
  }
  return 0;
}

std::string SweepRun::describe() const {
  std::ostringstream s;
  switch (stage_) {
    case SweepRunStage::kWaitForData:
      s << "waiting for " << (have_frame_ ? "" : "the camera")
        << (have_frame_ || encoders_.valid() ? "" : " and ")
        << (encoders_.valid() ? "" : "the encoders");
      break;
    case SweepRunStage::kProbe: {
      const WheelCommand c = probe_.command();
      s << "minimum duty: " << name(c.wheel) << " wheel " << (c.sign > 0 ? "forward" : "backward")
        << " at duty " << formatNumber(probe_.duty(), 3);
      break;
    }
    case SweepRunStage::kSweep:
      s << controller_.describe() << ", " << collector_.coverage().summary();
      break;
    case SweepRunStage::kRefine: {
      s << "more views where the projection is least sure: round " << refine_round_ << "/"
        << options_.refine_rounds << ", heading " << std::min(refine_next_ + 1, refine_headings_.size())
        << "/" << refine_headings_.size() << " (around";
      for (const ViewTarget& t : targets_)
        s << " (" << formatNumber(t.pixel.x, 3) << ", " << formatNumber(t.pixel.y, 3) << ") px";
      s << "), " << calibrationViews().size() << " views";
      break;
    }
    case SweepRunStage::kJudge:
      s << "calibrating " << calibrationViews().size() << " views with each lens model";
      break;
    case SweepRunStage::kSwept:
      s << "swept: " << collector_.views().size() << " views in " << collector_.frames()
        << " frames, " << controller_.steps() << " steps";
      break;
    case SweepRunStage::kFailed:
      s << "failed";
      break;
  }
  return s.str();
}

StageStatus SweepRun::status() const {
  StageStatus s;
  s.step = name(stage_);
  s.progress = progress();
  s.text = describe();
  s.figures = {{"views", collector_.coverage().views},
               {"sharp_views", static_cast<double>(sharpViews().size())},
               {"frames", framesProcessed()},
               {"steps", controller_.steps()},
               {"refine_rounds", refine_round_},
               {"views_not_seen_still", views_not_seen_still_},
               {"elapsed_s", elapsedS()}};
  return s;
}

StageResult SweepRun::finish(const StageOutput& output) {
  calibration_ = calibrate();  // throws when the gate refuses it
  StageResult r = writeCameraStageFile(output, camera_info_format_, camera_.board, calibration_,
                                       calibrationViews(), frames_);
  const MinDutyResult d = minDuty();
  r.figures.insert(r.figures.end(), {{"sweep_s", elapsedS()},
                                     {"min_duty_left_forward", d.left_forward},
                                     {"min_duty_left_backward", d.left_backward},
                                     {"min_duty_right_forward", d.right_forward},
                                     {"min_duty_right_backward", d.right_backward}});
  r.log += ", sweep " + formatNumber(elapsedS(), 4) + " s";
  return r;
}

void useNominalCamera(const CameraIntrinsics& nominal, bool as_guess,
                      CameraCalibrationConfig& camera, SweepRunOptions& run) {
  if (as_guess) camera.calibration.initial_camera_matrix = nominal.cameraMatrix();
  run.sweep.camera_hfov_rad = 2 * std::atan(nominal.width / (2 * nominal.fx));
}

}  // namespace camera
}  // namespace autocal
