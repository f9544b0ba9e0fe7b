// The wheel stage recomputed from a recording (see wheel_replay.h): paper 000 §3.4's iteration on
// the recorded drives, the deadband fit on their encoder rates.
#include "autocal/wheels/wheel_replay.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/markers/tag_detector.h"

namespace autocal {
namespace wheels {

namespace {
/// A duty this small is no command [1].
constexpr double kZeroDuty = 1e-6;

/// The deadband offsets the live run commanded its first drive through: it drove both wheels at
/// drive_speed_mps with the initial ratio, d = o + (1 − o)·u, so o = (d − u)/(1 − u). The live
/// run's guesses came from the camera stage's probe or a parameter, which the replay does not
/// see; the fit's rebase of k (addDriveToFit) starts from them.
KinematicsParams withFirstDriveOffsets(KinematicsParams p, const WheelDuties& duties,
                                       const WheelRunOptions& o) {
  const double trim = trimFromSpeedRatio(o.trim.initial_ratio, p.gain);
  const double w = o.drive_speed_mps / p.radius;
  auto offset = [](double duty, double u, double guess) {
    const double offset = (std::abs(duty) - u) / (1 - u);
    return u < 1 && offset >= 0 && offset < 0.6 ? offset : guess;
  };
  p.deadband_left = offset(duties.left, (p.gain - trim) * w / p.k, p.deadband_left);
  p.deadband_right = offset(duties.right, (p.gain + trim) * w / p.k, p.deadband_right);
  return p;
}
}  // namespace

WheelReplay::WheelReplay(const WheelRunOptions& options) : options_(options) {
  options_.validate();
}

WheelReplay::~WheelReplay() = default;

WheelReplay::Kind WheelReplay::classify(const WheelDuties& d) {
  const bool l = std::abs(d.left) > kZeroDuty, r = std::abs(d.right) > kZeroDuty;
  if (!l && !r) return Kind::kStill;
  if (l && r && d.left > 0 && d.right > 0) return Kind::kForward;
  if (l && r && d.left < 0 && d.right < 0) return Kind::kBack;
  return Kind::kTurn;
}

void WheelReplay::addCommand(double stamp_s, const WheelDuties& duties) {
  const Command c{stamp_s, classify(duties), duties};
  if (c.kind == Kind::kForward || c.kind == Kind::kBack) {
    const auto at =
        std::upper_bound(drive_commands_.begin(), drive_commands_.end(), stamp_s,
                         [](double t, const Command& o) { return t < o.stamp_s; });
    drive_commands_.insert(at, c);
  }
  if (commands_.empty() || stamp_s >= commands_.back().stamp_s) {
    // The same motion commanded again adds nothing (the robot repeats its command at its rate).
    if (commands_.empty() ? c.kind == Kind::kStill : c.kind == commands_.back().kind) return;
    commands_.push_back(c);
    return;
  }
  // Received after a later one: put in its place.
  const auto at = std::upper_bound(commands_.begin(), commands_.end(), stamp_s,
                                   [](double t, const Command& o) { return t < o.stamp_s; });
  commands_.insert(at, c);
  // Frames kept for a still that this command shows was none (or not yet settled).
  const std::vector<Segment> all = segments();
  frames_.erase(std::remove_if(frames_.begin(), frames_.end(),
                               [&](const Frame& f) {
                                 return !undecided(f.stamp_s) &&
                                        !settledAt(segmentAt(all, f.stamp_s), f.stamp_s);
                               }),
                frames_.end());
}

void WheelReplay::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                              int ticks_per_revolution, double /*now_s*/) {
  if (ticks_per_revolution <= 0)
    throw InputError("encoder resolution must be > 0 ticks per revolution");
  if (!encoders_.add(stamp_s, left_ticks, right_ticks).accepted) return;
  ticks_per_rev_ = ticks_per_revolution;
  readings_.push_back({stamp_s, encoders_.left(), encoders_.right()});
}

std::vector<WheelReplay::Segment> WheelReplay::segments(bool with_samples) const {
  std::vector<Segment> out(1);  // the robot stands until the first command
  out.back().start_s = -std::numeric_limits<double>::infinity();
  for (const Command& c : commands_) {
    if (c.kind == out.back().kind) continue;
    out.back().end_s = c.stamp_s;
    Segment s;
    s.kind = c.kind;
    s.start_s = c.stamp_s;
    s.drive.duties = {std::abs(c.duties.left), std::abs(c.duties.right)};
    s.drive.backward = c.kind == Kind::kBack;
    s.drive.start_s = c.stamp_s;
    out.push_back(std::move(s));
  }
  out.back().end_s = std::numeric_limits<double>::infinity();
  for (Segment& s : out) {
    if (!with_samples) break;
    if (s.kind != Kind::kForward && s.kind != Kind::kBack) continue;
    s.drive.end_s = s.end_s;
    const auto from =
        std::lower_bound(drive_commands_.begin(), drive_commands_.end(), s.start_s,
                         [](const Command& o, double t) { return o.stamp_s < t; });
    for (auto c = from; c != drive_commands_.end() && c->stamp_s < s.end_s; ++c)
      s.drive.commands.push_back({c->stamp_s, c->duties.left, c->duties.right});
    for (const Reading& r : readings_) {
      if (r.stamp_s >= s.start_s && r.stamp_s < s.end_s) {
        s.drive.samples.push_back({r.stamp_s, r.left, r.right});
        s.drive.end_s = std::isfinite(s.end_s) ? s.end_s : r.stamp_s;
      }
    }
  }
  return out;
}

const WheelReplay::Segment& WheelReplay::segmentAt(const std::vector<Segment>& segments,
                                                   double stamp_s) {
  const auto after = std::upper_bound(segments.begin(), segments.end(), stamp_s,
                                      [](double t, const Segment& s) { return t < s.start_s; });
  return *std::prev(after);  // the first segment starts at -inf
}

const WheelReplay::Reading& WheelReplay::readingAt(double stamp_s) const {
  const auto after = std::upper_bound(readings_.begin(), readings_.end(), stamp_s,
                                      [](double t, const Reading& r) { return t < r.stamp_s; });
  return after == readings_.begin() ? readings_.front() : *std::prev(after);
}

double WheelReplay::lastChangeAt(double stamp_s) const {
  auto changed = std::upper_bound(readings_.begin(), readings_.end(), stamp_s,
                                  [](double t, const Reading& r) { return t < r.stamp_s; });
  if (changed == readings_.begin()) return std::numeric_limits<double>::infinity();
  --changed;
  while (changed != readings_.begin() && std::prev(changed)->left == changed->left &&
         std::prev(changed)->right == changed->right)
    --changed;
  return changed->stamp_s;
}

bool WheelReplay::stillAt(double since_s, double stamp_s, double still_s) const {
  if (readings_.empty() || stamp_s < readings_.front().stamp_s) return false;
  const double latest_s = readingAt(stamp_s).stamp_s;
  return latest_s >= since_s && latest_s - lastChangeAt(stamp_s) >= still_s;
}

bool WheelReplay::settledAt(const Segment& s, double stamp_s) const {
  if (s.kind != Kind::kStill || stamp_s < s.start_s + options_.settle_s) return false;
  return stamp_s >= s.start_s + kMaxSettleS || stillAt(s.start_s, stamp_s, options_.still_s);
}

bool WheelReplay::undecided(double stamp_s) const {
  return commands_.empty() || stamp_s >= commands_.back().stamp_s;
}

std::vector<const WheelReplay::Frame*> WheelReplay::framesIn(const Segment& s) const {
  std::vector<const Frame*> out;
  for (const Frame& f : frames_)
    if (f.stamp_s >= s.start_s && f.stamp_s < s.end_s &&
        (!frames_used_.empty() || settledAt(s, f.stamp_s)))
      out.push_back(&f);
  return out;
}

bool WheelReplay::measured(const std::vector<const Frame*>& frames) const {
  // WheelRun's rule: heading_frames frames with a tag, or max_frames_without_tags without. Before
  // detection, as many as the rule may need.
  int with_tags = 0, without_tags = 0, undetected = 0;
  for (const Frame* f : frames) {
    if (!f->detected)
      ++undetected;
    else if (measureHeading(f->sightings, options_.heading).valid)
      ++with_tags;
    else
      ++without_tags;
    if (with_tags >= options_.heading_frames || without_tags >= options_.max_frames_without_tags)
      return true;
  }
  return with_tags + without_tags + undetected >=
         options_.heading_frames + options_.max_frames_without_tags - 1;
}

bool WheelReplay::wantsFrame(double stamp_s) const {
  if (!frames_used_.empty()) return frames_used_.count(stamp_s) > 0;
  if (readings_.empty()) return false;
  const std::vector<Segment> all = segments();
  const Segment& s = segmentAt(all, stamp_s);
  if (settledAt(s, stamp_s) && !measured(framesIn(s))) return true;
  if (!undecided(stamp_s) || !stillAt(s.start_s, stamp_s, options_.still_s)) return false;
  // Past the latest command received, with the encoders still: the robot may stand in a still
  // whose command is received later. The frame is kept (as many as a still may need since the
  // wheels last moved) until the commands say where it belongs.
  const double still_from_s = lastChangeAt(stamp_s);
  int since = 0;
  for (const Frame& f : frames_) since += f.stamp_s >= still_from_s;
  return since < options_.heading_frames + options_.max_frames_without_tags - 1;
}

void WheelReplay::detect(Frame& f) const {
  for (const auto& d : detector_->detect(f.image))
    f.sightings.push_back(sightTag(d, options_.mount));
  f.detected = true;
  f.image.release();
}

void WheelReplay::addFrame(double stamp_s, const cv::Mat& image) {
  if (!wantsFrame(stamp_s)) return;
  if (image.empty() || image.depth() != CV_8U)
    throw InputError("a frame must be a non-empty 8-bit image");
  Frame f;
  f.stamp_s = stamp_s;
  f.image = image.clone();
  if (detector_) detect(f);
  const auto at = std::upper_bound(frames_.begin(), frames_.end(), stamp_s,
                                   [](double t, const Frame& o) { return t < o.stamp_s; });
  frames_.insert(at, std::move(f));
}

void WheelReplay::setIntrinsics(const CameraIntrinsics& intrinsics) {
  detector_ = makeFloorTagDetector(options_, intrinsics);
  for (Frame& f : frames_)
    if (!f.detected) detect(f);
}

HeadingMeasurement WheelReplay::stillHeading(const Segment& s) const {
  // The frames WheelRun's rule took, in stamp order: up to heading_frames with a tag, or up to
  // max_frames_without_tags without.
  std::vector<TagSighting> all;
  int with_tags = 0, without_tags = 0;
  for (const Frame* f : framesIn(s)) {
    if (with_tags >= options_.heading_frames || without_tags >= options_.max_frames_without_tags)
      break;
    if (measureHeading(f->sightings, options_.heading).valid) {
      ++with_tags;
      all.insert(all.end(), f->sightings.begin(), f->sightings.end());
    } else {
      ++without_tags;
    }
  }
  return measureHeading(all, options_.heading);
}

WheelReplayResult WheelReplay::result() const {
  if (!detector_) throw CalibrationError("the wheel replay never got the camera's intrinsics");
  if (ticks_per_rev_ <= 0) throw CalibrationError("the recording holds no encoder reading");
  TrimEstimator estimator(options_.trim);
  MotorFitter fitter(motorFitOptions(options_));
  WheelReplayResult out;
  const std::vector<Segment> all = segments(true);
  const size_t n = all.size();
  // The ticks where a drive ended: when the still after it ended (the robot had coasted to rest),
  // as WheelRun reads them once settled.
  auto ticksAfter = [&](size_t i) {
    if (i + 2 < n && all[i + 1].kind == Kind::kStill) return readingAt(all[i + 2].start_s).left;
    if (i + 1 < n && all[i + 1].kind != Kind::kStill) return readingAt(all[i + 1].start_s).left;
    return readings_.back().left;
  };
  KinematicsParams commanded = options_.kinematics;
  const auto first_forward = std::find_if(
      all.begin(), all.end(), [](const Segment& s) { return s.kind == Kind::kForward; });
  if (options_.compensate_deadband && first_forward != all.end())
    commanded = withFirstDriveOffsets(commanded, first_forward->drive.duties, options_);
  bool last_forward_counted = false;
  bool turned_since_forward = false;
  int settled_iteration = -1;
  for (size_t i = 0; i < n; ++i) {
    const Segment& s = all[i];
    if (s.kind == Kind::kTurn) turned_since_forward = true;
    if (s.kind == Kind::kStill) {
      ++out.stills;
      if (stillHeading(s).valid) ++out.measured;
      continue;
    }
    if (s.kind == Kind::kBack) {
      // WheelRun fits the drive back of an iteration, not the one of a leave (there is none).
      if (last_forward_counted && options_.compensate_deadband) {
        addDriveToFit(s.drive, ticks_per_rev_, commanded, options_.drive_speed_mps, fitter,
                      estimator);
      }
      last_forward_counted = false;
      continue;
    }
    if (s.kind != Kind::kForward) continue;
    // A forward drive of the iteration (paper §3.4) is driven back after the still that measures
    // it; the drive out of the tag field (§5.1) is not.
    last_forward_counted =
        i + 2 < n && all[i + 1].kind == Kind::kStill && all[i + 2].kind == Kind::kBack;
    // As WheelRun: the first drive after a re-alignment's steps only takes up the backlash (once
    // per update).
    const bool settling = turned_since_forward && estimator.iterations() > 0 &&
                          settled_iteration != estimator.iterations();
    if (settling) settled_iteration = estimator.iterations();
    turned_since_forward = false;
    if (!last_forward_counted) continue;
    ++out.drives;
    if (!estimator.converged()) {
      // The drive went out with the ratio the live run had then (k = u_r/u_l above the offsets
      // of that time): the replay takes it from the recorded duties, so that an update it could
      // not measure (a still whose frames it did not get) is not carried into every later one.
      const KinematicsParams p =
          calibratedKinematics(commanded, estimator.ratio(), fitter, options_.compensate_deadband);
      const double u_left = removeDeadband(s.drive.duties.left, p.deadband_left);
      const double u_right = removeDeadband(s.drive.duties.right, p.deadband_right);
      if (u_left > 0 && u_right > 0) estimator.rebase(u_right / u_left);
    }
    if (options_.compensate_deadband) {
      addDriveToFit(s.drive, ticks_per_rev_, commanded, options_.drive_speed_mps, fitter,
                    estimator);
    }
    if (estimator.converged() || settling) continue;
    const bool still_before = i > 0 && all[i - 1].kind == Kind::kStill;
    const HeadingMeasurement before =
        still_before ? stillHeading(all[i - 1]) : HeadingMeasurement();
    const HeadingMeasurement after = stillHeading(all[i + 1]);
    if (!before.valid || !after.valid) continue;  // WheelRun drives back without an update too
    const double left_angle =
        (ticksAfter(i) - readingAt(s.start_s).left) * 2 * M_PI / ticks_per_rev_;
    estimator.addDrive(wrapAngle(after.heading_rad - before.heading_rad), left_angle);  // throws
  }
  if (out.drives == 0) {
    throw CalibrationError("the recording holds no drive over the tags driven back (" +
                           std::to_string(out.stills) +
                           " stills): it does not cover the wheel stage's iteration");
  }
  if (estimator.iterations() == 0) {
    throw CalibrationError("no drive of the recording had the tags in view before and after (" +
                           std::to_string(out.drives) + " drives)");
  }
  out.converged = estimator.converged();
  out.iterations = estimator.history();
  out.left = fitter.left();
  out.right = fitter.right();
  out.kinematics =
      calibratedKinematics(commanded, estimator.ratio(), fitter, options_.compensate_deadband);
  return out;
}

int WheelReplay::drives() const {
  int d = 0;
  for (const Segment& s : segments()) d += s.kind == Kind::kForward || s.kind == Kind::kBack;
  return d;
}

int WheelReplay::stills() const {
  int d = 0;
  for (const Segment& s : segments()) d += s.kind == Kind::kStill;
  return d;
}

int WheelReplay::framesKept() const {
  int k = 0;
  for (const Frame& f : frames_) k += !f.detected;
  return k;
}

std::string WheelReplay::describe() const {
  return "replaying: " + std::to_string(drives()) + " drives, " + std::to_string(stills()) +
         " stills, " + std::to_string(framesKept()) + " frames kept" +
         (detector_ ? "" : " (waiting for the intrinsics)");
}

bool WheelReplay::addFrame(double stamp_s, const cv::Mat& image, const std::string& /*source*/) {
  if (!wantsFrame(stamp_s)) return false;
  addFrame(stamp_s, image);
  return true;
}

StageStatus WheelReplay::status() const {
  StageStatus s;
  s.step = "replay";
  s.progress = -1;
  s.text = describe();
  s.figures = {{"drives", static_cast<double>(drives())},
               {"stills", static_cast<double>(stills())}};
  return s;
}

const WheelReplayResult& WheelReplay::finalResult() {
  if (final_) return *final_;
  WheelReplayResult r = result();  // throws
  if (!r.converged) {
    throw CalibrationError("the replayed iteration did not converge (" +
                           std::to_string(r.iterations.size()) + " updates over " +
                           std::to_string(r.drives) + " drives): nothing written");
  }
  if (options_.compensate_deadband && !(r.left.valid && r.right.valid)) {
    throw CalibrationError(std::string("the replayed motor fit found no deadband for the ") +
                           wheelsWithoutLine(r.left, r.right) +
                           " (" + std::to_string(r.drives) +
                           " drives): nothing written rather than the guesses");
  }
  final_ = std::make_unique<WheelReplayResult>(std::move(r));
  return *final_;
}

StageResult WheelReplay::finish(const StageOutput& output) {
  const WheelReplayResult& result = finalResult();
  const KinematicsParams& k = result.kinematics;
  StageResult r;
  r.file = kinematicsPath(output.calibration_root, output.veh);
  writeKinematicsFile(r.file, k);  // validates first; throws on failure
  r.figures = {{"trim", k.trim},
               {"trim_before", options_.kinematics.trim},
               {"k", result.iterations.back().ratio_after},
               {"deadband_left", k.deadband_left},
               {"deadband_right", k.deadband_right},
               {"drives", static_cast<double>(result.iterations.size())},
               {"last_dtheta_rad", result.iterations.back().delta_theta_rad}};
  r.log = "replay: trim " + formatNumber(k.trim, 4) + ", deadband " +
          formatNumber(k.deadband_left, 4) + "/" + formatNumber(k.deadband_right, 4) + ", " +
          std::to_string(result.iterations.size()) + " updates over " +
          std::to_string(result.drives) + " drives, " + std::to_string(result.measured) + "/" +
          std::to_string(result.stills) + " stills measured";
  return r;
}

}  // namespace wheels
}  // namespace autocal
