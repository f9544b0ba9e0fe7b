#include "autocal/wheels/lane_refiner.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace wheels {

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double clampAbs(double x, double limit) { return std::max(-limit, std::min(limit, x)); }

}  // namespace

void LaneRefinerOptions::validate() const {
  detector.validate();
  heading.validate();
  mount.validate();
  kinematics.validate();
  checkConfig(first_tag_id >= 0, "first_tag_id", "must be >= 0");
  checkConfig(num_tags >= 0, "num_tags", "must be >= 0 (0: any tag after the first)");
  checkConfig(start_max_distance_m > 0, "start_max_distance_m", "must be > 0 [m]");
  checkConfig(start_max_heading_rad > 0 && start_max_heading_rad < max_heading_rad,
              "start_max_heading_rad", "must be within (0, max_heading_rad) [rad]");
  checkConfig(start_max_lateral_m > 0, "start_max_lateral_m", "must be > 0 [m]");
  checkConfig(speed_mps > 0 && speed_mps <= 1.0, "speed_mps", "must be within (0, 1] [m/s]");
  checkConfig(heading_gain_per_s > 0, "heading_gain_per_s", "must be > 0 [1/s]");
  checkConfig(max_omega_radps > 0, "max_omega_radps", "must be > 0 [rad/s]");
  checkConfig(orient_tolerance_rad > 0, "orient_tolerance_rad", "must be > 0 [rad]");
  checkConfig(max_orient_s > 0, "max_orient_s", "must be > 0 [s]");
  checkConfig(lateral_gain_rad_per_m >= 0, "lateral_gain_rad_per_m", "must be >= 0 [rad/m]");
  checkConfig(max_lateral_correction_rad >= 0 && max_lateral_correction_rad < max_heading_rad,
              "max_lateral_correction_rad", "must be within [0, max_heading_rad) [rad]");
  checkConfig(settle_s >= 0, "settle_s", "must be >= 0 [s]");
  checkConfig(straight_m > 0, "straight_m", "must be > 0 [m]");
  checkConfig(max_straight_deviation_rad > 0, "max_straight_deviation_rad", "must be > 0 [rad]");
  checkConfig(min_frames_per_part >= 3, "min_frames_per_part", "must be >= 3");
  checkConfig(min_part_m > 0 && min_part_m <= straight_m, "min_part_m",
              "must be within (0, straight_m] [m]");
  checkConfig(max_part_deviation > 0 && max_part_deviation < 1, "max_part_deviation",
              "must be within (0, 1)");
  checkConfig(min_parts_per_pass >= 1, "min_parts_per_pass", "must be >= 1");
  checkConfig(max_heading_rad > 0 && max_heading_rad < M_PI / 2, "max_heading_rad",
              "must be within (0, pi/2) [rad]");
  checkConfig(tags_lost_s > 0, "tags_lost_s", "must be > 0 [s]");
  checkConfig(max_pass_s > 0, "max_pass_s", "must be > 0 [s]");
  checkConfig(stable_passes >= 1, "stable_passes", "must be >= 1");
  checkConfig(stable_tolerance >= 0, "stable_tolerance", "must be >= 0 [trim]");
  checkConfig(apply_threshold >= 0, "apply_threshold", "must be >= 0 [trim]");
}

const char* name(LanePhase phase) {
  switch (phase) {
    case LanePhase::kIdle:
      return "idle";
    case LanePhase::kOrient:
      return "orient";
    case LanePhase::kStraight:
      return "straight";
  }
  return "?";
}

LaneRefiner::LaneRefiner(const LaneRefinerOptions& options)
    : options_(options),
      trim_(options.kinematics.trim),
      last_heading_rad_(std::nan("")),
      last_lateral_m_(std::nan("")) {
  options_.validate();
}

LaneRefiner::LaneRefiner(const LaneRefinerOptions& options, const CameraIntrinsics& intrinsics)
    : LaneRefiner(options) {
  detector_.reset(new markers::TagDetector(options_.detector, intrinsics));
  detector_->setFloorNormal(options_.mount.floorUpInCamera());
}

LaneRefiner::~LaneRefiner() = default;

void LaneRefiner::setCurrentTrim(double trim) {
  if (inPass()) return;  // a pass drives with the trim it started with
  speedRatioFromTrim(trim, options_.kinematics.gain);  // throws ConfigError when |trim| >= gain
  trim_ = trim;
}

bool LaneRefiner::isPassTag(int id) const {
  if (options_.num_tags == 0) return true;
  return id >= options_.first_tag_id && id < options_.first_tag_id + options_.num_tags;
}

void LaneRefiner::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                              int ticks_per_revolution) {
  if (ticks_per_revolution <= 0 || !std::isfinite(stamp_s))
    throw InputError("encoder reading with a non-positive resolution or a non-finite stamp");
  if (!encoders_.empty() && stamp_s < encoders_.back().stamp_s) return;  // out of order: dropped
  const double per_tick = 2 * M_PI / ticks_per_revolution;
  encoders_.push_back({stamp_s, left_ticks * per_tick, right_ticks * per_tick});
  // A pass needs its own span only; idle keeps a few seconds.
  const double keep_from = inPass() ? pass_.start_s - 1.0 : stamp_s - 2.0;
  size_t drop = 0;
  while (drop + 2 < encoders_.size() && encoders_[drop].stamp_s < keep_from) ++drop;
  if (drop > 64) encoders_.erase(encoders_.begin(), encoders_.begin() + drop);
}

double LaneRefiner::leftAngleAt(double stamp_s) const {
  if (encoders_.empty()) return 0;
  if (stamp_s <= encoders_.front().stamp_s) return encoders_.front().left_rad;
  if (stamp_s >= encoders_.back().stamp_s) return encoders_.back().left_rad;
  const auto it = std::lower_bound(encoders_.begin(), encoders_.end(), stamp_s,
                                   [](const EncoderSample& e, double t) { return e.stamp_s < t; });
  const EncoderSample& b = *it;
  const EncoderSample& a = *(it - 1);
  const double f = b.stamp_s > a.stamp_s ? (stamp_s - a.stamp_s) / (b.stamp_s - a.stamp_s) : 1.0;
  return a.left_rad + f * (b.left_rad - a.left_rad);
}

double LaneRefiner::meanWheelAngle() const {
  return encoders_.empty() ? 0.0 : 0.5 * (encoders_.back().left_rad + encoders_.back().right_rad);
}

void LaneRefiner::addFrame(double stamp_s, const cv::Mat& image) {
  if (!detector_) throw ConfigError("LaneRefiner: addFrame needs the camera intrinsics");
  last_detections_ = detector_->detect(image);
  std::vector<TagSighting> sightings;
  sightings.reserve(last_detections_.size());
  for (const auto& d : last_detections_) sightings.push_back(sightTag(d, options_.mount));
  addSightings(stamp_s, sightings);
}

void LaneRefiner::addSightings(double stamp_s, const std::vector<TagSighting>& sightings) {
  std::vector<TagSighting> ours;
  const TagSighting* first = nullptr;
  for (const auto& s : sightings) {
    if (!isPassTag(s.id) && s.id != options_.first_tag_id) continue;
    ours.push_back(s);
    if (s.id == options_.first_tag_id) first = &s;
  }
  const HeadingMeasurement m = measureHeading(ours, options_.heading);
  if (!m.valid) return;
  // The lateral offset from every tag in range that agrees with the frame's heading.
  const double lateral_m = measureLateralM(ours, m, options_.heading);
  if (std::isnan(lateral_m)) return;
  last_heading_rad_ = m.heading_rad;
  last_lateral_m_ = lateral_m;
  last_heading_stamp_s_ = stamp_s;

  if (phase_ == LanePhase::kIdle) {
    // §5.2: the first marker with the predefined id, seen while driving right in the lane.
    if (first && first->distance_m <= options_.start_max_distance_m &&
        std::abs(m.heading_rad) <= options_.start_max_heading_rad &&
        std::abs(last_lateral_m_) <= options_.start_max_lateral_m) {
      startPass(stamp_s);
    }
    return;
  }
  last_tag_s_ = stamp_s;
  if (options_.num_tags > 0) {
    for (const auto& s : ours)
      if (s.id == options_.first_tag_id + options_.num_tags - 1) last_id_seen_ = true;
  }
  if (phase_ == LanePhase::kStraight && window_open_ &&
      stamp_s >= straight_cmd_s_ + options_.settle_s)
    samples_.push_back({stamp_s, m.heading_rad});
}

void LaneRefiner::startPass(double now_s) {
  pass_ = LanePass();
  pass_.start_s = now_s;
  phase_ = LanePhase::kOrient;
  orient_start_s_ = now_s;
  ever_started_ = true;
  last_tag_s_ = now_s;
  last_id_seen_ = options_.num_tags == 1;
  samples_.clear();
  window_open_ = false;
}

double LaneRefiner::passRatio() const {
  std::vector<double> trims;
  for (const auto& p : pass_.parts)
    if (!p.rejected) trims.push_back(p.trim);
  const double gain = options_.kinematics.gain;
  if (trims.empty()) return speedRatioFromTrim(trim_, gain);
  // The pass's running estimate (§5.2: each marker refines the coefficient, which then applies),
  // kept well inside the valid range.
  return speedRatioFromTrim(clampAbs(median(trims), 0.5 * gain), gain);
}

CarCommand LaneRefiner::straightCommand() const {
  // Straight with the ratio r instead of the kinematics node's r0: a feed-forward ω with
  // (v + ω·b/2)/(v − ω·b/2) = r/r0 (the node's wheel speeds are proportional to its commands).
  const double r0 = speedRatioFromTrim(trim_, options_.kinematics.gain);
  const double q = passRatio() / r0;
  CarCommand c;
  c.v_mps = options_.speed_mps;
  c.omega_radps = 2 * options_.speed_mps * (q - 1) / (options_.kinematics.baseline * (q + 1));
  return c;
}

double LaneRefiner::targetHeading() const {
  if (!std::isfinite(last_lateral_m_)) return 0;
  return clampAbs(-options_.lateral_gain_rad_per_m * last_lateral_m_,
                  options_.max_lateral_correction_rad);
}

void LaneRefiner::startStraight(double now_s) {
  phase_ = LanePhase::kStraight;
  straight_cmd_s_ = now_s;
  window_open_ = false;
  samples_.clear();
  part_ratio_ = passRatio();
}

void LaneRefiner::endPart() {
  const std::vector<Sample> samples = std::move(samples_);
  samples_.clear();
  window_open_ = false;
  if (static_cast<int>(samples.size()) < options_.min_frames_per_part) return;
  // §3.4 over one straight part: the heading's least-squares slope against the left wheel's angle
  // (every frame, not two readings), Δθ = slope·φ_l.
  std::vector<double> phi;
  phi.reserve(samples.size());
  for (const auto& s : samples) phi.push_back(leftAngleAt(s.stamp_s));
  const double span = phi.back() - phi.front();
  if (span * options_.kinematics.radius < options_.min_part_m) return;
  double mp = 0, mh = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    mp += phi[i];
    mh += samples[i].heading_rad;
  }
  mp /= samples.size();
  mh /= samples.size();
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    sxy += (phi[i] - mp) * (samples[i].heading_rad - mh);
    sxx += (phi[i] - mp) * (phi[i] - mp);
  }
  if (sxx <= 0) return;
  const double slope = sxy / sxx;
  LanePart part;
  part.commanded_ratio = part_ratio_;
  part.left_angle_rad = span;
  part.delta_theta_rad = slope * span;
  part.frames = static_cast<int>(samples.size());
  // k_i = 1 + Δθ·L/(R·φ_l): the true right/left ratio was k_i times the commanded one's share,
  // so the ratio that drives straight is commanded/k_i (see trim_estimator.h).
  part.k_i = 1 + slope * options_.kinematics.baseline / options_.kinematics.radius;
  part.rejected = !(std::abs(part.k_i - 1) <= options_.max_part_deviation);
  if (!part.rejected)
    part.trim = trimFromSpeedRatio(part_ratio_ / part.k_i, options_.kinematics.gain);
  pass_.parts.push_back(part);
}

void LaneRefiner::endPass(double now_s, bool aborted, const std::string& reason) {
  pass_.end_s = now_s;
  pass_.aborted = aborted;
  pass_.reason = reason;
  phase_ = LanePhase::kIdle;
  samples_.clear();
  window_open_ = false;
  if (!aborted) {
    std::vector<double> trims;
    for (const auto& p : pass_.parts)
      if (!p.rejected) trims.push_back(p.trim);
    if (static_cast<int>(trims.size()) >= options_.min_parts_per_pass) {
      pass_.estimated = true;
      pass_.estimate = median(trims);
    } else {
      pass_.reason = "only " + std::to_string(trims.size()) + " straight parts measured, " +
                     std::to_string(options_.min_parts_per_pass) + " needed";
    }
  }
  passes_.push_back(pass_);
  if (!pass_.estimated) return;
  // §5.2: apply only a value that is constant over the last passes and significantly different
  // from the one in use.
  std::vector<double> recent;
  for (auto it = passes_.rbegin();
       it != passes_.rend() && static_cast<int>(recent.size()) < options_.stable_passes; ++it)
    if (it->estimated) recent.push_back(it->estimate);
  if (static_cast<int>(recent.size()) < options_.stable_passes) return;
  const auto mm = std::minmax_element(recent.begin(), recent.end());
  if (*mm.second - *mm.first > options_.stable_tolerance) return;
  double mean = 0;
  for (double r : recent) mean += r;
  mean /= recent.size();
  if (!(std::abs(mean - trim_) > options_.apply_threshold)) return;
  trim_ = mean;
  pending_apply_ = true;
  ++applications_;
  passes_.back().applied = true;
}

LaneOutput LaneRefiner::finishOutput(LaneOutput out) {
  if (pending_apply_) {
    out.apply = true;
    out.trim = trim_;
    pending_apply_ = false;
  }
  return out;
}

LaneOutput LaneRefiner::update(double now_s) {
  LaneOutput out;
  if (phase_ == LanePhase::kIdle) {
    if (options_.drive_to_first_tag && !ever_started_) {
      out.commanding = true;
      out.cmd.v_mps = options_.speed_mps;
    }
    return finishOutput(out);
  }
  // Fail-safe first: a pass that goes wrong stops commanding and records nothing.
  if (now_s - pass_.start_s > options_.max_pass_s) {
    endPass(now_s, true, "pass longer than max_pass_s");
    return finishOutput(out);
  }
  if (std::isfinite(last_heading_rad_) && std::abs(last_heading_rad_) > options_.max_heading_rad) {
    endPass(now_s, true,
            "heading " + formatNumber(last_heading_rad_, 3) + " rad beyond max_heading_rad");
    return finishOutput(out);
  }
  if (now_s - last_tag_s_ > options_.tags_lost_s) {
    if (options_.num_tags > 0 && !last_id_seen_) {
      endPass(now_s, true, "tags lost before the segment's last tag");
      return finishOutput(out);
    }
    // The segment's end: the last part counts with what it has.
    if (phase_ == LanePhase::kStraight) endPart();
    endPass(now_s, false, "");
    return finishOutput(out);
  }

  if (phase_ == LanePhase::kOrient) {
    const double target = targetHeading();
    const bool fresh = now_s - last_heading_stamp_s_ <= 0.2;
    const double err = target - last_heading_rad_;
    if (fresh && (std::abs(err) < options_.orient_tolerance_rad ||
                  now_s - orient_start_s_ >= options_.max_orient_s)) {
      startStraight(now_s);
    } else {
      out.commanding = true;
      out.cmd = straightCommand();
      if (fresh)
        out.cmd.omega_radps +=
            clampAbs(options_.heading_gain_per_s * err, options_.max_omega_radps);
      return finishOutput(out);
    }
  }

  // kStraight
  if (!window_open_ && now_s >= straight_cmd_s_ + options_.settle_s) {
    window_open_ = true;
    straight_start_wheel_ = meanWheelAngle();
    straight_start_heading_ = last_heading_rad_;
  }
  const double travelled_m =
      (meanWheelAngle() - straight_start_wheel_) * options_.kinematics.radius;
  const bool strayed =
      std::abs(last_heading_rad_ - straight_start_heading_) > options_.max_straight_deviation_rad;
  if (window_open_ && (travelled_m >= options_.straight_m || strayed)) {
    endPart();
    phase_ = LanePhase::kOrient;  // re-orient coaxially with the next marker (§5.2)
    orient_start_s_ = now_s;
  }
  out.commanding = true;
  out.cmd = straightCommand();  // a part's ratio is fixed while it lasts (no part is added)
  if (phase_ == LanePhase::kOrient)
    out.cmd.omega_radps +=
        clampAbs(options_.heading_gain_per_s * (targetHeading() - last_heading_rad_),
                 options_.max_omega_radps);
  return finishOutput(out);
}

std::string LaneRefiner::describe() const {
  std::ostringstream s;
  s << name(phase_) << ", " << passes_.size() << " passes, " << applications_ << " applied, trim "
    << formatNumber(trim_, 5);
  if (inPass()) {
    s << ", pass parts " << pass_.parts.size() << ", running trim "
      << formatNumber(trimFromSpeedRatio(passRatio(), options_.kinematics.gain), 5);
  } else if (!passes_.empty()) {
    const LanePass& p = passes_.back();
    s << ", last pass: "
      << (p.aborted     ? "aborted (" + p.reason + ")"
          : p.estimated ? "estimate " + formatNumber(p.estimate, 5)
                        : "no estimate (" + p.reason + ")");
  }
  if (std::isfinite(last_heading_rad_))
    s << ", heading " << formatNumber(last_heading_rad_, 4) << " rad, lateral "
      << formatNumber(last_lateral_m_, 4) << " m";
  return s.str();
}

}  // namespace wheels
}  // namespace autocal
