// The wheel stage recomputed from a recording (see wheel_replay.h): paper 000 §3.4's iteration on
// the recorded drives, the deadband fit on their encoder rates.
#include "autocal/wheels/wheel_replay.h"

#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/markers/tag_detector.h"

namespace autocal {
namespace wheels {

namespace {
/// A duty this small is no command [1].
constexpr double kZeroDuty = 1e-6;
}  // namespace

WheelReplay::WheelReplay(const WheelRunOptions& options) : options_(options) {
  options_.validate();
  segments_.push_back(Segment());  // the robot stands until the first command
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
  const Kind kind = classify(duties);
  if (kind == segments_.back().kind) return;  // the same motion, commanded again
  Segment& last = segments_.back();
  if (last.kind == Kind::kForward || last.kind == Kind::kBack) last.drive.end_s = stamp_s;
  Segment s;
  s.kind = kind;
  s.start_s = stamp_s;
  s.start_left = encoders_.rawLeft();
  s.start_right = encoders_.rawRight();
  s.drive.duties = {std::abs(duties.left), std::abs(duties.right)};
  s.drive.start_s = stamp_s;
  segments_.push_back(std::move(s));
}

void WheelReplay::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                              int ticks_per_revolution) {
  if (ticks_per_revolution <= 0)
    throw InputError("encoder resolution must be > 0 ticks per revolution");
  if (!encoders_.valid()) {
    for (Segment& s : segments_) s.start_left = left_ticks, s.start_right = right_ticks;
  }
  if (!encoders_.add(stamp_s, left_ticks, right_ticks).accepted) return;
  ticks_per_rev_ = ticks_per_revolution;
  Segment& s = segments_.back();
  if (s.kind == Kind::kForward || s.kind == Kind::kBack)
    s.drive.samples.push_back({stamp_s, double(left_ticks), double(right_ticks)});
}

bool WheelReplay::stillMeasured(const Segment& s) const {
  // WheelRun's rule: heading_frames frames with a tag, or max_frames_without_tags without. Before
  // detection, as many as the rule may need.
  if (s.with_tags >= options_.heading_frames || s.without_tags >= options_.max_frames_without_tags)
    return true;
  const int most = options_.heading_frames + options_.max_frames_without_tags - 1;
  return static_cast<int>(s.kept.size()) + s.with_tags + s.without_tags >= most;
}

bool WheelReplay::wantsFrame(double stamp_s) const {
  const Segment& s = segments_.back();
  if (s.kind != Kind::kStill || !encoders_.valid() || stillMeasured(s)) return false;
  return SettleRule{options_.settle_s, options_.still_s, kMaxSettleS}.settled(s.start_s, stamp_s,
                                                                              encoders_);
}

void WheelReplay::detectInto(Segment& s, const cv::Mat& image) {
  std::vector<TagSighting> frame;
  for (const auto& d : detector_->detect(image)) frame.push_back(sightTag(d, options_.mount));
  if (s.with_tags >= options_.heading_frames || s.without_tags >= options_.max_frames_without_tags)
    return;  // measured by the frames before (the kept ones exceed what the rule used)
  if (measureHeading(frame, options_.heading).valid) {
    ++s.with_tags;
    s.frames.push_back(std::move(frame));
  } else {
    ++s.without_tags;
  }
}

void WheelReplay::addFrame(double stamp_s, const cv::Mat& image) {
  if (!wantsFrame(stamp_s)) return;
  if (image.empty() || image.depth() != CV_8U)
    throw InputError("a frame must be a non-empty 8-bit image");
  Segment& s = segments_.back();
  if (detector_) {
    detectInto(s, image);
  } else {
    s.kept.emplace_back(stamp_s, image.clone());
  }
}

void WheelReplay::setIntrinsics(const CameraIntrinsics& intrinsics) {
  detector_ = makeFloorTagDetector(options_, intrinsics);
  for (Segment& s : segments_) {
    for (const auto& f : s.kept) detectInto(s, f.second);
    s.kept.clear();
    s.kept.shrink_to_fit();
  }
}

HeadingMeasurement WheelReplay::stillHeading(const Segment& s) const {
  std::vector<TagSighting> all;
  for (const auto& f : s.frames) all.insert(all.end(), f.begin(), f.end());
  return measureHeading(all, options_.heading);
}

WheelReplayResult WheelReplay::result() const {
  if (!detector_) throw CalibrationError("the wheel replay never got the camera's intrinsics");
  if (ticks_per_rev_ <= 0) throw CalibrationError("the recording holds no encoder reading");
  TrimEstimator estimator(options_.trim);
  MotorFitter fitter(motorFitOptions(options_));
  WheelReplayResult out;
  const size_t n = segments_.size();
  // The ticks where a drive ended: when the still after it ended (the robot had coasted to rest),
  // as WheelRun reads them once settled.
  auto ticksAfter = [&](size_t i, bool left) {
    if (i + 2 < n && segments_[i + 1].kind == Kind::kStill)
      return left ? segments_[i + 2].start_left : segments_[i + 2].start_right;
    if (i + 1 < n && segments_[i + 1].kind != Kind::kStill)
      return left ? segments_[i + 1].start_left : segments_[i + 1].start_right;
    return left ? encoders_.rawLeft() : encoders_.rawRight();
  };
  bool last_forward_counted = false;
  for (size_t i = 0; i < n; ++i) {
    const Segment& s = segments_[i];
    if (s.kind == Kind::kStill) {
      ++out.stills;
      if (stillHeading(s).valid) ++out.measured;
      continue;
    }
    if (s.kind == Kind::kBack) {
      // WheelRun fits the drive back of an iteration, not the one of a leave (there is none).
      if (last_forward_counted && options_.compensate_deadband)
        fitter.addDrive(s.drive, ticks_per_rev_);
      last_forward_counted = false;
      continue;
    }
    if (s.kind != Kind::kForward) continue;
    // A forward drive of the iteration (paper §3.4) is driven back after the still that measures
    // it; the drive out of the tag field (§5.1) is not.
    last_forward_counted =
        i + 2 < n && segments_[i + 1].kind == Kind::kStill && segments_[i + 2].kind == Kind::kBack;
    if (!last_forward_counted) continue;
    ++out.drives;
    if (options_.compensate_deadband) fitter.addDrive(s.drive, ticks_per_rev_);
    if (estimator.converged()) continue;
    const bool still_before = i > 0 && segments_[i - 1].kind == Kind::kStill;
    const HeadingMeasurement before =
        still_before ? stillHeading(segments_[i - 1]) : HeadingMeasurement();
    const HeadingMeasurement after = stillHeading(segments_[i + 1]);
    if (!before.valid || !after.valid) continue;  // WheelRun drives back without an update too
    const double left_angle = (ticksAfter(i, true) - s.start_left) * 2 * M_PI / ticks_per_rev_;
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
  out.kinematics = calibratedKinematics(options_.kinematics, estimator.ratio(), fitter,
                                        options_.compensate_deadband);
  return out;
}

int WheelReplay::drives() const {
  int d = 0;
  for (const Segment& s : segments_) d += s.kind == Kind::kForward || s.kind == Kind::kBack;
  return d;
}

int WheelReplay::stills() const {
  int d = 0;
  for (const Segment& s : segments_) d += s.kind == Kind::kStill;
  return d;
}

int WheelReplay::framesKept() const {
  int k = 0;
  for (const Segment& s : segments_) k += static_cast<int>(s.kept.size());
  return k;
}

std::string WheelReplay::describe() const {
  return "replaying: " + std::to_string(drives()) + " drives, " + std::to_string(stills()) +
         " stills, " + std::to_string(framesKept()) + " frames kept" +
         (detector_ ? "" : " (waiting for the intrinsics)");
}

}  // namespace wheels
}  // namespace autocal
