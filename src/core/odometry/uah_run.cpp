// The UAH experiments driven by the robot (paper 002 §2.1–2.3); see uah_run.h.
#include "autocal/odometry/uah_run.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "autocal/camera/calibration_files.h"
#include "autocal/errors.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/odometry/calibration_file.h"

namespace autocal {
namespace odometry {

namespace {
constexpr double kRateWindowS = 0.5;
std::string deg(double rad) { return formatNumber(rad * 180.0 / M_PI, 3) + " deg"; }
bool isTurn(UahExperiment e) {
  return e == UahExperiment::kPivotLeftStopped || e == UahExperiment::kPivotRightStopped ||
         e == UahExperiment::kSpin;
}
}  // namespace

const char* name(UahExperiment experiment) {
  switch (experiment) {
    case UahExperiment::kWait:
      return "wait";
    case UahExperiment::kPivotLeftStopped:
      return "pivot_left_stopped";
    case UahExperiment::kPivotRightStopped:
      return "pivot_right_stopped";
    case UahExperiment::kSpin:
      return "spin";
    case UahExperiment::kFace:
      return "face";
    case UahExperiment::kStraight:
      return "straight";
    case UahExperiment::kDone:
      return "done";
    case UahExperiment::kFailed:
      return "failed";
  }
  return "?";
}

void UahRunOptions::validate() const {
  nominal.validate();
  straight.validate();
  EncoderDriveOptions::validate();
  checkConfig(rounds >= 1 && rounds <= 20, "rounds", "must be within [1, 20]");
  checkConfig(pivot_experiments >= 1 && pivot_experiments <= 10, "pivot_experiments",
              "must be within [1, 10]");
  checkConfig(pivot_rate_pulses_per_s > 0, "pivot_rate_pulses_per_s", "must be > 0 [pulses/s]");
  checkConfig(spin_rate_pulses_per_s > 0, "spin_rate_pulses_per_s", "must be > 0 [pulses/s]");
  checkConfig(straight_rate_pulses_per_s > 0, "straight_rate_pulses_per_s",
              "must be > 0 [pulses/s]");
  checkConfig(straight_length_m > 0.2 && straight_length_m < 50, "straight_length_m",
              "must be within (0.2, 50) [m]");
  checkConfig(straight_runs >= 1, "straight_runs", "must be >= 1");
  checkConfig(max_straight_retries >= 0, "max_straight_retries", "must be >= 0");
  checkConfig(heading_gain_duty_per_pulse >= 0, "heading_gain_duty_per_pulse", "must be >= 0");
  checkConfig(heading_integral_duty_per_pulse_s >= 0, "heading_integral_duty_per_pulse_s",
              "must be >= 0");
  checkConfig(held_heading_gain_duty_per_pulse >= 0, "held_heading_gain_duty_per_pulse",
              "must be >= 0");
  checkConfig(straight_ramp_s > 0, "straight_ramp_s", "must be > 0 [s]");
  checkConfig(straight_fast_rate_pulses_per_s == 0 ||
                  straight_fast_rate_pulses_per_s > 1.5 * straight_rate_pulses_per_s,
              "straight_fast_rate_pulses_per_s",
              "must be 0 (one rate) or over 1.5 times straight_rate_pulses_per_s [pulses/s] (the "
              "two speeds' duties are a line's two points)");
  checkConfig(max_length_mismatch > 0 && max_length_mismatch < 1, "max_length_mismatch",
              "must be within (0, 1)");
  checkConfig(face_tolerance_rad > 0 && face_tolerance_rad < M_PI / 2, "face_tolerance_rad",
              "must be within (0, pi/2) [rad]");
  checkConfig(max_face_turns >= 0 && max_face_turns <= 20, "max_face_turns",
              "must be within [0, 20] (0: the straight runs go where the spin leaves the robot)");
  checkConfig(min_clearance_m >= 0, "min_clearance_m", "must be >= 0 [m]");
  checkConfig(max_trim_disagreement < 0.1, "max_trim_disagreement",
              "must be < 0.1 (negative: the kinematics file's trim is never replaced)");
  checkConfig(max_decorrelation_fraction > 0 && max_decorrelation_fraction <= 0.5,
              "max_decorrelation_fraction", "must be within (0, 0.5]");
  checkConfig(min_range_spread_m >= 0, "min_range_spread_m", "must be >= 0 [m]");
  checkConfig(max_invalid_range_fraction >= 0 && max_invalid_range_fraction < 1,
              "max_invalid_range_fraction", "must be within [0, 1)");
  checkConfig(range_timeout_s > 0, "range_timeout_s", "must be > 0 [s]");
  checkConfig(max_duration_s >= 0, "max_duration_s", "must be >= 0 [s] (0: no limit)");
  checkConfig(length_timeout_s >= 0, "length_timeout_s", "must be >= 0 [s] (0: no limit)");
  RoundDetectionOptions d = detection;
  d.expected_pulses_per_round = 100;  // set per experiment
  d.validate();
}

std::string UahRunOptions::summary() const {
  return std::to_string(rounds) + " rounds x " + std::to_string(pivot_experiments) +
         " pivot experiments per wheel, spin, " + std::to_string(straight_runs) +
         " straight runs of " + formatNumber(straight_length_m, 3) + " m (heading within " +
         deg(straight.max_heading_deviation_rad) + ", up to " +
         std::to_string(max_straight_retries) + " retries" +
         (straight_fast_rate_pulses_per_s > 0
              ? "; forward " + formatNumber(straight_rate_pulses_per_s, 3) + " then " +
                    formatNumber(straight_fast_rate_pulses_per_s, 3) + " pulses/s"
              : "") +
         ")";
}

UahRun::UahRun(const UahRunOptions& options) : options_(options), drive_(options, kMaxSettleS) {
  options_.validate();
}

void UahRun::fail(const std::string& why) {
  experiment_ = UahExperiment::kFailed;
  motion_ = Motion::kNone;
  duties_ = {};
  awaiting_length_ = false;
  failure_ = why;
  throw CalibrationError(why);
}

void UahRun::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                         int /*ticks_per_revolution*/, double /*now_s*/) {
  if (failed() || done()) return;
  EncoderTracker::Step step;
  const std::string jump = drive_.add(stamp_s, left_ticks, right_ticks, &step);
  if (!jump.empty()) fail(jump + "; the pulse counts cannot be trusted");
  if (!step.accepted || step.first || motion_ == Motion::kNone) return;
  drive_.keepSample();
}

void UahRun::addRange(double stamp_s, double range_m) {
  if (failed() || done()) return;
  last_range_arrival_s_ = std::max(last_range_arrival_s_, stamp_s);
  const bool valid = std::isfinite(range_m) && range_m >= options_.detection.min_range_m &&
                     range_m <= options_.detection.max_range_m;
  if (isTurn(experiment_) && motion_ != Motion::kNone) {
    ranges_.push_back({stamp_s, range_m});
    if (!valid) ++invalid_ranges_;
  }
  if (experiment_ == UahExperiment::kStraight && motion_ == Motion::kDrive && straight_dir_ > 0 &&
      drive_.clock().started() && stamp_s >= drive_.clock().startS() && valid &&
      range_m < options_.min_clearance_m) {
    fail("straight run cut short: an obstacle " + formatNumber(range_m, 3) + " m ahead after " +
         formatNumber(
             std::abs(encoders().right() - start_right_) * options_.nominal.right_m_per_pulse, 3) +
         " m (needs " + formatNumber(options_.straight_length_m, 3) + " m of free straight line)");
  }
}

DiffDriveParams UahRun::headingParams() const {
  // The heading only needs c_L/c_R (Ed) and b in the same units: c_R nominal, b from the spin.
  DiffDriveParams p = options_.nominal;
  p.left_m_per_pulse = p.right_m_per_pulse / Ed_;
  if (spin_ppr_ > 0) {
    p.wheelbase_m = spin_ppr_ * (p.left_m_per_pulse + p.right_m_per_pulse) / (2 * M_PI);
  }
  return p;
}

RoundDetectionOptions UahRun::detectionFor(UahExperiment experiment) const {
  // §2.1's N_t from the nominal parameters: 2π·b/c on a stopped wheel, π·b/c̄ spinning in place.
  RoundDetectionOptions d = options_.detection;
  const DiffDriveParams& n = options_.nominal;
  switch (experiment) {
    case UahExperiment::kPivotLeftStopped:
      d.expected_pulses_per_round = 2 * M_PI * n.wheelbase_m / n.right_m_per_pulse;
      break;
    case UahExperiment::kPivotRightStopped:
      d.expected_pulses_per_round = 2 * M_PI * n.wheelbase_m / n.left_m_per_pulse;
      break;
    default:
      d.expected_pulses_per_round =
          2 * M_PI * n.wheelbase_m / (n.left_m_per_pulse + n.right_m_per_pulse);
  }
  return d;
}

double UahRun::turnPulses(const EncoderDrive::Sample& s) const {
  const double dl = s.left - start_left_, dr = s.right - start_right_;
  switch (experiment_) {
    case UahExperiment::kPivotLeftStopped:
      return dr;
    case UahExperiment::kPivotRightStopped:
      return dl;
    case UahExperiment::kFace:  // a pivot: the moving wheel
      return face_dir_ > 0 ? dr : dl;
    default:
      // The spin turns by (N_R·c_R − N_L·c_L)/b = c_R·(N_R − N_L/Ed)/b (N_L < 0 here). On the pulse
      // axis p = (N_R − N_L/Ed)·Ed/(1 + Ed) a round is 2π·b/(c_L + c_R) pulses whether or not the
      // two wheels kept exactly the same rate, and p = N when they did (§2.3's N_s).
      return (dr - dl / Ed_) * Ed_ / (1 + Ed_);
  }
}

std::vector<RangeSample> UahRun::turnRangeSamples() const {
  // Each reading gets the pulses interpolated at its stamp between the encoder readings around it
  // (§2.1: the range as a function of the moving wheel's pulses).
  std::vector<RangeSample> out;
  if (drive_.samples().size() < 2) return out;
  size_t j = 0;
  for (const auto& r : ranges_) {
    const double t = r[0];
    if (t < drive_.samples().front().stamp_s || t > drive_.samples().back().stamp_s) continue;
    while (j + 1 < drive_.samples().size() && drive_.samples()[j + 1].stamp_s < t) ++j;
    if (j + 1 >= drive_.samples().size()) break;
    const EncoderDrive::Sample& a = drive_.samples()[j];
    const EncoderDrive::Sample& b = drive_.samples()[j + 1];
    const double span = b.stamp_s - a.stamp_s;
    const double f = span > 0 ? (t - a.stamp_s) / span : 0.0;
    const double pa = turnPulses(a), pb = turnPulses(b);
    out.push_back({pa + f * (pb - pa), r[1]});
  }
  return out;
}

double UahRun::rangeSpreadM() const {
  double n = 0, sum = 0, sum2 = 0;
  for (const auto& r : ranges_) {
    if (!std::isfinite(r[1]) || r[1] < options_.detection.min_range_m ||
        r[1] > options_.detection.max_range_m) {
      continue;
    }
    n += 1, sum += r[1], sum2 += r[1] * r[1];
  }
  if (n < 2) return 0.0;
  return std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
}

double UahRun::decorrelationFraction() const {
  const RoundDetectionOptions det = detectionFor(experiment_);
  double first = 0;
  const std::vector<double> x = resampleOnPulses(turnRangeSamples(), det, &first);
  const int max_lag = static_cast<int>(det.expected_pulses_per_round / 2);
  const std::vector<double> r = normalizedAutocorrelation(x, max_lag);
  for (int k = 1; k < static_cast<int>(r.size()); ++k) {
    if (std::isfinite(r[k]) && r[k] < 0.3) return k / det.expected_pulses_per_round;
  }
  return 0.5;
}

void UahRun::refuseFlatScene() {
  const double spread = rangeSpreadM();
  if (spread >= options_.min_range_spread_m) return;
  fail(std::string(name(experiment_)) + ": the range barely changes as the robot turns (spread " +
       formatNumber(1000 * spread, 3) + " mm, limit " +
       formatNumber(1000 * options_.min_range_spread_m, 3) +
       " mm): the scene around the robot is circular, symmetric or featureless, so no whole round "
       "can be told apart (paper 002 §3.1); place walls or boxes at different distances");
}

void UahRun::startTurn(UahExperiment experiment, double now_s) {
  experiment_ = experiment;
  motion_ = Motion::kTurn;
  drive_.startMotion(now_s, options_.start_duty);
  drive_.restartSamples();
  start_left_ = encoders().left(), start_right_ = encoders().right();
  ranges_.clear();
  invalid_ranges_ = 0;
  online_ppr_ = 0;
  turn_target_pulses_ = 0;
  last_detection_error_.clear();
  next_check_pulses_ = 1.5 * detectionFor(experiment).expected_pulses_per_round;
}

void UahRun::startStraight(double now_s) {
  experiment_ = UahExperiment::kStraight;
  motion_ = Motion::kDrive;
  drive_.restartSamples();
  start_left_ = encoders().left(), start_right_ = encoders().right();
  heading_integral_ = 0;
  run_duty_sum_[0] = run_duty_sum_[1] = 0;
  run_duty_count_ = 0;
  fast_duty_sum_[0] = fast_duty_sum_[1] = 0;
  fast_duty_count_ = 0;
  fast_since_s_ = -1;
  slow_pulses_ = fast_pulses_ = PulseLine();
  settle_sum_[0] = settle_sum_[1] = 0;
  settle_count_ = 0;
  holding_ = false;
  // Both wheels start at the mean duty the spin settled at (near their equal-rate duty), the right
  // one then follows the straight run's rate, reached over straight_ramp_s (a soft start keeps
  // the heading transient small).
  drive_.startMotion(
      now_s, spin_duty_[0] > 0 ? 0.5 * (spin_duty_[0] + spin_duty_[1]) : options_.start_duty);
}

void UahRun::stop(double now_s) {
  duties_ = {};
  motion_ = Motion::kSettle;
  drive_.stop(now_s);
}

int UahRun::round() const {
  if (!isTurn(experiment_) || online_ppr_ <= 0 || drive_.samples().empty()) return 0;
  return static_cast<int>(std::floor(turnPulses(drive_.samples().back()) / online_ppr_)) + 1;
}

void UahRun::finishTurn() {
  UahTurn turn;
  turn.experiment = experiment_;
  turn.pulses_turned = turnPulses(drive_.samples().back());
  turn.range_readings = static_cast<int>(ranges_.size());
  turn.invalid_readings = invalid_ranges_;
  const std::string what = std::string(name(experiment_)) + ": ";
  if (turn.range_readings == 0) fail(what + "no range readings while turning");
  const double invalid = static_cast<double>(invalid_ranges_) / turn.range_readings;
  if (invalid > options_.max_invalid_range_fraction) {
    fail(what + formatNumber(100 * invalid, 3) +
         " % of the range readings were dropouts or out of range (limit " +
         formatNumber(100 * options_.max_invalid_range_fraction, 3) +
         " %): the walls must be within the sensor's range all around");
  }
  try {
    turn.detection = detectWholeRound(turnRangeSamples(), detectionFor(experiment_));
  } catch (const CalibrationError& e) {
    refuseFlatScene();
    fail(what + e.what());
  }
  // A circular or symmetric scene seen from off its centre (a pivot, a spin that drifts) gives one
  // smooth wave per round: its autocorrelation has a round peak, but so wide that the round is
  // not told apart from its neighbours. A scene with features decorrelates within a few % of a
  // round (§2.1: "the obstacles found should not be uniform").
  turn.decorrelation_fraction = decorrelationFraction();
  if (turn.decorrelation_fraction > options_.max_decorrelation_fraction) {
    fail(what + "the range changes only slowly as the robot turns (it takes " +
         formatNumber(100 * turn.decorrelation_fraction, 3) +
         " % of a round to decorrelate, limit " +
         formatNumber(100 * options_.max_decorrelation_fraction, 3) +
         " %): the scene around the robot is circular, symmetric or featureless, so the round "
         "cannot be located precisely (paper 002 §3.1); place walls or boxes at different "
         "distances");
  }
  if (turn.detection.rounds_used < std::min(options_.rounds, 2)) {
    fail(what + "only " + std::to_string(turn.detection.rounds_used) +
         " round peaks agreed in the autocorrelation (the scene changed while turning?)");
  }
  turns_.push_back(turn);
  const double ppr = turn.detection.pulses_per_round;
  // The turn's angle by its own pulses per round: whole rounds and what it coasted past them. A
  // pivot on the stopped left wheel and the spin turn counter-clockwise, a pivot on the stopped
  // right wheel clockwise.
  const double sign = experiment_ == UahExperiment::kPivotRightStopped ? -1.0 : 1.0;
  heading_rad_ =
      std::remainder(heading_rad_ + sign * 2 * M_PI * turn.pulses_turned / ppr, 2 * M_PI);
  switch (experiment_) {
    case UahExperiment::kPivotLeftStopped:
      right_ppr_left_stopped_.push_back(ppr);
      ++pivot_done_[0];
      break;
    case UahExperiment::kPivotRightStopped:
      left_ppr_right_stopped_.push_back(ppr);
      ++pivot_done_[1];
      break;
    default:
      spin_ppr_ = ppr;
      spin_duty_[0] = drive_.duty(0), spin_duty_[1] = drive_.duty(1);
  }
}

void UahRun::nextAfterTurns(double now_s) {
  if (experiment_ == UahExperiment::kSpin) {
    faceOrStraight(now_s);
    return;
  }
  // Alternate the stopped wheel (§2.2): left, right, left, right, ...
  if (pivot_done_[0] < options_.pivot_experiments && pivot_done_[0] <= pivot_done_[1]) {
    startTurn(UahExperiment::kPivotLeftStopped, now_s);
  } else if (pivot_done_[1] < options_.pivot_experiments) {
    startTurn(UahExperiment::kPivotRightStopped, now_s);
  } else {
    // §2.2: Ed = N_L/N_R, needed by the spin's pulse axis and the straight runs' heading.
    try {
      Ed_ = estimateEd(right_ppr_left_stopped_, left_ppr_right_stopped_).Ed;
    } catch (const Error& e) {
      fail(e.what());
    }
    startTurn(UahExperiment::kSpin, now_s);
  }
}

void UahRun::faceOrStraight(double now_s) {
  const double off = std::abs(heading_rad_);
  // A robot whose wheels break away with a jump turns by some degrees at the least and may swing
  // about the heading: after max_face_turns it goes on within three tolerances (a 3 m run then
  // ends at most 0.5 m off the line), and fails beyond.
  const bool last = face_turns_ >= options_.max_face_turns;
  if (off <= options_.face_tolerance_rad || options_.max_face_turns == 0 ||
      (last && off <= 3 * options_.face_tolerance_rad)) {
    straight_dir_ = 1;
    startStraight(now_s);
    return;
  }
  if (last) {
    fail("the robot could not turn back to the heading it had when the stage began: still " +
         deg(off) + " off after " + std::to_string(face_turns_) +
         " turns (max_face_turns; within " + deg(3 * options_.face_tolerance_rad) +
         " needed): the straight runs need the free line it faced");
  }
  ++face_turns_;
  experiment_ = UahExperiment::kFace;
  motion_ = Motion::kTurn;
  drive_.startMotion(now_s, options_.start_duty);
  drive_.restartSamples();
  start_left_ = encoders().left(), start_right_ = encoders().right();
  // A pivot the long way round, by a round less the offset: a turn of a few degrees stops
  // wherever its wheel's breakaway and the late readings leave it (a robot swung 10-25 deg either
  // way about the heading), a pivot at its rate stops as the experiments' pivots do (0.5-2 deg
  // off). Counter-clockwise on the stopped left wheel, clockwise on the stopped right one, by the
  // pulses per round that wheel's pivots measured.
  face_dir_ = heading_rad_ > 0 ? 1 : -1;
  face_target_pulses_ = (2 * M_PI - off) / (2 * M_PI) * facePulsesPerRound();
}

int UahRun::coastIndex() const {
  switch (experiment_) {
    case UahExperiment::kPivotRightStopped:
      return 0;
    case UahExperiment::kPivotLeftStopped:
      return 1;
    case UahExperiment::kFace:
      return face_dir_ > 0 ? 1 : 0;
    default:
      return 2;
  }
}

double UahRun::facePulsesPerRound() const {
  const std::vector<double>& ppr =
      face_dir_ > 0 ? right_ppr_left_stopped_ : left_ppr_right_stopped_;
  double sum = 0;
  for (double v : ppr) sum += v;
  return sum / ppr.size();
}

WheelDuties UahRun::updateFace(double now_s, double dt_s) {
  const double p = turnPulses(drive_.samples().back());
  const double rate = options_.pivot_rate_pulses_per_s;
  // As the pivots stop on their rounds: early by the turns' coast at their rate.
  if (p >= face_target_pulses_ - coast_s_[coastIndex()] * rate) {
    stop_pulses_ = p, stop_rate_ = rate;
    stop(now_s);
    return duties_;
  }
  // Counter-clockwise: the right wheel drives; clockwise: the left one.
  const int side = face_dir_ > 0 ? 1 : 0;
  follow(side, rate, dt_s);
  checkStall(side, now_s);
  duties_ = {side == 0 ? drive_.duty(0) : 0.0, side == 1 ? drive_.duty(1) : 0.0};
  return duties_;
}

void UahRun::onSettled(double now_s) {
  if (experiment_ == UahExperiment::kFace) {
    // Where the turn back really ended, encoders still: turn again if it is still off.
    const double p = turnPulses(drive_.samples().back());
    heading_rad_ =
        std::remainder(heading_rad_ + face_dir_ * 2 * M_PI * p / facePulsesPerRound(), 2 * M_PI);
    if (stop_rate_ > 0) {
      coast_s_[coastIndex()] = std::clamp((p - stop_pulses_) / stop_rate_, 0.0, 1.0);
    }
    faceOrStraight(now_s);
    return;
  }
  if (isTurn(experiment_)) {
    // How long this turn coasted on after its stop: the next ones stop that much earlier.
    const double p = turnPulses(drive_.samples().back());
    if (stop_rate_ > 0) {
      coast_s_[coastIndex()] = std::clamp((p - stop_pulses_) / stop_rate_, 0.0, 1.0);
    }
    finishTurn();
    nextAfterTurns(now_s);
    return;
  }
  // A straight run: its pulses and heading are final; the caller measures the length.
  // The heading from whole ticks jumps by a pulse's worth (0.9 deg on a Duckiebot) as either
  // encoder steps: a centred mean over 5 readings (~0.17 s at 30 Hz) keeps the heading and
  // removes most of that quantisation before §2.3's threshold is applied.
  std::vector<std::pair<double, double>> cumulative;
  const int n = static_cast<int>(drive_.samples().size()), half = 2;
  for (int i = 0; i < n; ++i) {
    const int lo = std::max(0, i - half), hi = std::min(n - 1, i + half);
    double l = 0, r = 0;
    for (int j = lo; j <= hi; ++j) l += drive_.samples()[j].left, r += drive_.samples()[j].right;
    cumulative.push_back({l / (hi - lo + 1) - start_left_, r / (hi - lo + 1) - start_right_});
  }
  run_right_pulses_ = std::abs(drive_.samples().back().right - start_right_);
  run_max_dev_rad_ = maxHeadingDeviationRad(cumulative, headingParams());
  run_shortening_ = pathShortening(cumulative, headingParams());
  motion_ = Motion::kNone;
  awaiting_length_ = true;
  awaiting_since_s_ = now_s;
}

void UahRun::setStraightLength(double length_m) {
  if (!awaiting_length_) throw InputError("no straight run is waiting for its length");
  if (!std::isfinite(length_m) || length_m <= 0) {
    throw InputError("a straight run's length must be a positive number [m], got " +
                     formatNumber(length_m));
  }
  awaiting_length_ = false;
  const double odometry_m = run_right_pulses_ * options_.nominal.right_m_per_pulse;
  if (std::abs(length_m / odometry_m - 1) > options_.max_length_mismatch) {
    fail("straight run " + std::to_string(attempts_ + 1) + ": the given length " +
         formatNumber(length_m, 4) + " m is far from the " + formatNumber(odometry_m, 4) +
         " m the nominal right wheel counted (a run cut short, a slipping wheel or a wrong "
         "measurement)");
  }
  StraightRun run{length_m, run_right_pulses_, run_max_dev_rad_, run_shortening_};
  if (run_duty_count_ > 0) {
    run.mean_left_duty = run_duty_sum_[0] / run_duty_count_;
    run.mean_right_duty = run_duty_sum_[1] / run_duty_count_;
    run.slow_left_lag = slow_pulses_.leftLag(Ed_);
  }
  if (fast_duty_count_ > 0) {
    run.fast_left_duty = fast_duty_sum_[0] / fast_duty_count_;
    run.fast_right_duty = fast_duty_sum_[1] / fast_duty_count_;
    run.fast_left_lag = fast_pulses_.leftLag(Ed_);
  }
  run.forward = straight_dir_ > 0;
  straight_runs_.push_back(run);
  ++attempts_;
  // The runs that count: within the heading bound and agreeing on the distance per pulse.
  MmPerPulseEstimate agreeing;
  try {
    agreeing = estimateMmPerPulse(straight_runs_, options_.straight);
  } catch (const CalibrationError&) {
    // none kept yet
  }
  accepted_ = static_cast<int>(agreeing.accepted_runs.size());
  if (accepted_ >= options_.straight_runs) {
    finish();
    return;
  }
  const int bound = options_.straight_runs + options_.max_straight_retries;
  if (attempts_ >= bound) {
    std::string why;
    for (const std::string& r : agreeing.rejection_reasons) why += "; " + r;
    fail("only " + std::to_string(accepted_) + " of " + std::to_string(options_.straight_runs) +
         " straight runs kept the heading within " +
         deg(options_.straight.max_heading_deviation_rad) +
         " and agreed on the distance per pulse in " + std::to_string(attempts_) + " runs" +
         (why.empty() ? " (last deviated " + deg(run_max_dev_rad_) + ")" : why));
  }
  // The next run goes back along the same line (a rejected one is repeated that way too).
  straight_dir_ = -straight_dir_;
  startStraight(drive_.lastS());
}

void UahRun::finish() {
  try {
    result_ = computeUah(options_.nominal, right_ppr_left_stopped_, left_ppr_right_stopped_,
                         straight_runs_, spin_ppr_, options_.straight);
    checkOdometryCalibration(result_.toOdometryCalibration(""));
  } catch (const Error& e) {
    fail(e.what());
  }
  experiment_ = UahExperiment::kDone;
  motion_ = Motion::kNone;
  duties_ = {};
}

WheelDuties UahRun::update(double now_s) {
  if (done() || failed()) return {};
  double dt = 0;
  const std::string late = drive_.tick(now_s, motion_ != Motion::kNone, options_.max_duration_s,
                                       "UAH run", name(experiment_), &dt);
  if (!late.empty()) fail(late);
  if (!encoders().valid()) return {};
  if (experiment_ == UahExperiment::kWait) startTurn(UahExperiment::kPivotLeftStopped, now_s);
  if (awaiting_length_) {
    if (options_.length_timeout_s > 0 && now_s - awaiting_since_s_ > options_.length_timeout_s) {
      fail("no length given for straight run " + std::to_string(attempts_ + 1) + " in " +
           formatNumber(options_.length_timeout_s, 3) + " s");
    }
    return {};
  }
  if (motion_ == Motion::kSettle) {
    if (drive_.settled(now_s)) onSettled(now_s);
    if (motion_ == Motion::kSettle || motion_ == Motion::kNone) return duties_ = {};
  }
  if (motion_ == Motion::kNone) return {};
  drive_.clock().start(now_s);
  if (experiment_ == UahExperiment::kFace) return updateFace(now_s, dt);
  return motion_ == Motion::kTurn ? updateTurn(now_s, dt) : updateStraight(now_s, dt);
}

void UahRun::follow(int side, double target_pulses_per_s, double dt_s) {
  drive_.follow(side, drive_.rate(side, kRateWindowS), target_pulses_per_s, dt_s);
}

void UahRun::checkStall(int side, double now_s) {
  const std::string stall = drive_.stall(side, now_s);
  if (!stall.empty()) fail(std::string(name(experiment_)) + ": " + stall);
}

WheelDuties UahRun::updateTurn(double now_s, double dt_s) {
  const double moving_s = drive_.clock().elapsedS(now_s);
  if (moving_s > options_.range_timeout_s &&
      now_s - std::max(last_range_arrival_s_, drive_.clock().startS()) > options_.range_timeout_s) {
    fail(std::string(name(experiment_)) + ": the range sensor went silent");
  }
  const RoundDetectionOptions det = detectionFor(experiment_);
  const double nt = det.expected_pulses_per_round;
  const double p = turnPulses(drive_.samples().back());
  // §2.1: whole rounds come from the autocorrelation of what has been turned so far, checked
  // every tenth of a round; the turn ends after rounds + 1 detected rounds.
  if (p >= next_check_pulses_) {
    next_check_pulses_ = p + nt / 10;
    try {
      online_ppr_ = detectWholeRound(turnRangeSamples(), det).pulses_per_round;
      turn_target_pulses_ = (options_.rounds + 1) * online_ppr_;
    } catch (const CalibrationError& e) {
      last_detection_error_ = e.what();
      // Two expected rounds without a round: refuse a flat scene now rather than turn on.
      if (p >= 2 * nt * (1 + det.window_fraction)) refuseFlatScene();
    }
  }
  const double rate = experiment_ == UahExperiment::kSpin ? options_.spin_rate_pulses_per_s
                                                          : options_.pivot_rate_pulses_per_s;
  // Stop early by the time the last turn of its kind coasted on after its stop (see coast_s_).
  if (turn_target_pulses_ > 0 && p >= turn_target_pulses_ - coast_s_[coastIndex()] * rate) {
    stop_pulses_ = p, stop_rate_ = rate;
    stop(now_s);
    return duties_;
  }
  const double bound = (options_.rounds + 1.5) * nt * (1 + det.window_fraction);
  if (p > bound) {
    refuseFlatScene();
    fail(std::string(name(experiment_)) + ": no whole round found in " + formatNumber(p / nt, 3) +
         " expected rounds: " +
         (last_detection_error_.empty() ? "no detection yet" : last_detection_error_));
  }
  switch (experiment_) {
    case UahExperiment::kPivotLeftStopped:
      follow(1, rate, dt_s);
      checkStall(1, now_s);
      duties_ = {0.0, drive_.duty(1)};
      break;
    case UahExperiment::kPivotRightStopped:
      follow(0, rate, dt_s);
      checkStall(0, now_s);
      duties_ = {drive_.duty(0), 0.0};
      break;
    default:  // spin counter-clockwise
      follow(0, rate, dt_s);
      follow(1, rate, dt_s);
      checkStall(0, now_s);
      checkStall(1, now_s);
      duties_ = {-drive_.duty(0), drive_.duty(1)};
  }
  return duties_;
}

WheelDuties UahRun::updateStraight(double now_s, double dt_s) {
  // A straight run (§2.3): the right wheel at its rate; the left wheel at the rate that keeps
  // N_L·c_L = N_R·c_R (N_L = Ed·N_R), and a PI on the heading error N_R − N_L/Ed [pulses].
  const double dl = straight_dir_ * (encoders().left() - start_left_);
  const double dr = straight_dir_ * (encoders().right() - start_right_);
  const double target_pulses = options_.straight_length_m / options_.nominal.right_m_per_pulse;
  if (dr >= target_pulses) {
    stop(now_s);
    return duties_;
  }
  const double ramp =
      std::clamp(drive_.clock().elapsedS(now_s) / options_.straight_ramp_s, 0.0, 1.0);
  double rate = options_.spin_rate_pulses_per_s +
                ramp * (options_.straight_rate_pulses_per_s - options_.spin_rate_pulses_per_s);
  // A forward run at two speeds: its second half rises to the fast rate over the same ramp.
  const bool two_speeds = straight_dir_ > 0 && options_.straight_fast_rate_pulses_per_s > 0;
  const StraightRunWindows windows;
  if (two_speeds && dr >= windows.slow_end * target_pulses) {
    if (fast_since_s_ < 0) fast_since_s_ = now_s;
    rate += std::clamp((now_s - fast_since_s_) / options_.straight_ramp_s, 0.0, 1.0) *
            (options_.straight_fast_rate_pulses_per_s - options_.straight_rate_pulses_per_s);
  }
  follow(1, rate, dt_s);
  checkStall(0, now_s);
  checkStall(1, now_s);
  const double share = dr / target_pulses;
  const bool slow_window = share >= windows.slow_begin && share < windows.slow_end;
  const bool fast_window = share >= windows.fast_begin;
  const bool hold = two_speeds && (slow_window || fast_window);
  // The left duty moves with the right one; the PI on the heading error N_R − N_L/Ed makes up
  // the wheels' differences (deadbands, motor gains, Ed). Over a window at two speeds both duties
  // are held at the settling stretch's means (the integral kept as it was).
  const double error = dr - dl / Ed_;
  if (!hold) heading_integral_ += error * dt_s;
  double left = std::clamp(drive_.duty(1) + options_.heading_gain_duty_per_pulse * error +
                               options_.heading_integral_duty_per_pulse_s * heading_integral_,
                           0.0, options_.max_duty);
  double right = drive_.duty(1);
  if (hold) {
    if (!holding_) {
      if (settle_count_ > 0) {
        held_[0] = settle_sum_[0] / settle_count_, held_[1] = settle_sum_[1] / settle_count_;
      } else {
        held_[0] = left, held_[1] = right;
      }
      holding_ = true;
      hold_since_s_ = now_s;
      hold_error_ = error;
    }
    left = std::clamp(held_[0] + options_.held_heading_gain_duty_per_pulse * (error - hold_error_),
                      0.0, options_.max_duty);
    right = held_[1];
  } else {
    if (holding_) settle_sum_[0] = settle_sum_[1] = 0, settle_count_ = 0;
    holding_ = false;
    if (two_speeds && ((share >= windows.slow_settle && share < windows.slow_begin) ||
                       (share >= windows.fast_settle && share < windows.fast_begin))) {
      settle_sum_[0] += left, settle_sum_[1] += right, ++settle_count_;
    }
  }
  duties_ = {straight_dir_ * left, straight_dir_ * right};
  // The duties that held it straight, past the ramps and their transients.
  // Held, from hold_settle_s on: the wheels have reached the speeds of the duties by then.
  const bool settled = !hold || now_s - hold_since_s_ >= windows.hold_settle_s;
  if (settled && (two_speeds ? slow_window : share >= windows.begin)) {
    slow_pulses_.add(dl, dr);
    run_duty_sum_[0] += left;
    run_duty_sum_[1] += right;
    ++run_duty_count_;
  } else if (settled && two_speeds && fast_window) {
    fast_pulses_.add(dl, dr);
    fast_duty_sum_[0] += left;
    fast_duty_sum_[1] += right;
    ++fast_duty_count_;
  }
  return duties_;
}

double UahRun::progress() const {
  const double turns = 2.0 * options_.pivot_experiments + 1;
  const double straights = options_.straight_runs;
  double done_units = static_cast<double>(turns_.size()) + accepted_;
  if (done()) return 1.0;
  if (isTurn(experiment_) && turn_target_pulses_ > 0 && !drive_.samples().empty()) {
    done_units += std::min(1.0, turnPulses(drive_.samples().back()) / turn_target_pulses_);
  }
  return std::min(1.0, done_units / (turns + straights));
}

std::string UahRun::describe() const {
  std::string s = name(experiment_);
  if (isTurn(experiment_)) {
    s += " round " + std::to_string(std::min(round(), options_.rounds + 1)) + "/" +
         std::to_string(options_.rounds + 1);
    if (online_ppr_ > 0) s += ", " + formatNumber(online_ppr_, 5) + " pulses/round";
  } else if (experiment_ == UahExperiment::kFace) {
    s += " turn " + std::to_string(face_turns_) + ", " + deg(std::abs(heading_rad_)) +
         " from the starting heading";
  } else if (experiment_ == UahExperiment::kStraight) {
    s += " run " + std::to_string(attempts_ + 1) + " (" + std::to_string(accepted_) + "/" +
         std::to_string(options_.straight_runs) + " accepted)";
    if (awaiting_length_) s += ", waiting for its length";
  }
  if (Ed_ != 1.0) s += ", Ed " + formatNumber(Ed_, 6);
  if (spin_ppr_ > 0) s += ", spin " + formatNumber(spin_ppr_, 6) + " pulses/round";
  if (failed()) s += ": " + failure_;
  return s;
}

StageStatus UahRun::status() const {
  StageStatus s;
  s.step = name(experiment_);
  // A helper or a person acts on each new round, straight run and wait for a length.
  s.key = std::to_string(round()) + "/" + std::to_string(straightRun()) + "/" +
          std::to_string(needsStraightLength()) + "/" + std::to_string(face_turns_);
  s.progress = progress();
  s.text = describe();
  s.figures = {{"round", static_cast<double>(round())},
               {"pulses_per_round", pulsesPerRound()},
               {"straight_run", static_cast<double>(straightRun())},
               {"awaiting_length", needsStraightLength() ? 1.0 : 0.0},
               {"run_start_s", straightRunStartS()},
               {"elapsed_s", elapsedS()}};
  return s;
}

StageResult writeUahStageFile(const StageOutput& output, const UahResult& result,
                              const std::vector<UahTurn>& turns, double elapsed_s) {
  const OdometryCalibration c = result.toOdometryCalibration(output.veh);
  StageResult r;
  r.file = odometryCalibrationPath(output.calibration_root, output.veh);
  writeOdometryCalibration(r.file, c);  // the quality gate first; throws on failure
  double spin_ppr = 0;
  for (const auto& t : turns)
    if (t.experiment == UahExperiment::kSpin) spin_ppr = t.detection.pulses_per_round;
  r.figures = {
      {"Ed", c.Ed},
      {"Eb", c.Eb},
      {"wheelbase_m", c.wheelbase_m},
      {"left_m_per_pulse", c.left_m_per_pulse},
      {"right_m_per_pulse", c.right_m_per_pulse},
      {"right_pulses_per_round_left_stopped", result.ed.right_pulses_per_round},
      {"left_pulses_per_round_right_stopped", result.ed.left_pulses_per_round},
      {"spin_pulses_per_round", spin_ppr},
      {"straight_runs_accepted", static_cast<double>(result.straight.accepted_runs.size())},
      {"elapsed_s", elapsed_s}};
  r.log = "Ed " + formatNumber(c.Ed, 5) + ", wheelbase " + formatNumber(c.wheelbase_m, 5) +
          " m (Eb " + formatNumber(c.Eb, 4) + "), c_L " +
          formatNumber(1000 * c.left_m_per_pulse, 5) + " mm, c_R " +
          formatNumber(1000 * c.right_m_per_pulse, 5) + " mm per pulse, " +
          formatNumber(elapsed_s, 4) + " s";
  return r;
}

namespace {

/// The duty that would have held the wheel level with the other one where `duty` left it behind
/// by `lag` (a share of the other's pulses), through the deadband `offset`: the wheel's speed goes
/// with duty − offset.
double levelDuty(double duty, double lag, double offset) {
  return lag < 1 ? offset + (duty - offset) / (1 - lag) : duty;
}

/// The two speeds' fit (straightRunFit) with each run's left duties taken level by its lags
/// through the deadbands `left_offset` (the left wheel's) and `params`' gain and mean deadband.
StraightRunFit fitTwoSpeeds(const std::vector<StraightRun>& runs,
                            const std::vector<int>& accepted,
                            const wheels::KinematicsParams& params, double left_offset) {
  StraightRunFit fit;
  fit.trim = std::numeric_limits<double>::quiet_NaN();
  fit.deadband_left = params.deadband_left, fit.deadband_right = params.deadband_right;
  // The two speeds' mean duty pairs (slow: l1, r1; fast: l2, r2) over the forward runs.
  double l1 = 0, r1 = 0, l2 = 0, r2 = 0;
  int n = 0;
  for (const int i : accepted) {
    if (i < 0 || i >= static_cast<int>(runs.size())) continue;
    const StraightRun& r = runs[static_cast<size_t>(i)];
    if (!r.forward || !(r.mean_left_duty > 0) || !(r.mean_right_duty > 0) ||
        !(r.fast_left_duty > 0) || !(r.fast_right_duty > 0))
      continue;
    l1 += levelDuty(r.mean_left_duty, r.slow_left_lag, left_offset), r1 += r.mean_right_duty;
    l2 += levelDuty(r.fast_left_duty, r.fast_left_lag, left_offset), r2 += r.fast_right_duty;
    ++n;
  }
  if (n == 0 || !(l2 - l1 > 0)) return fit;
  // Equal wheel speeds through the deadband compensation d = o + (1 − o)·u put the duty pairs on
  // the line r = s·l + c through (o_l, o_r), with s = k·(1 − o_r)/(1 − o_l) for k = u_r/u_l. The
  // line's place gives the deadbands' difference (their mean, the wheel stage's, kept: a shared
  // offset hardly turns the robot), its slope then k.
  const double s = (r2 - r1) / (l2 - l1);
  const double c = r1 / n - s * l1 / n;
  const double mean = 0.5 * (params.deadband_left + params.deadband_right);
  const double difference = 2 * (c - mean * (1 - s)) / (1 + s);
  const double o_l = mean - 0.5 * difference, o_r = mean + 0.5 * difference;
  if (!(s > 0) || !(o_l >= 0) || !(o_r >= 0) || !(o_l < l1 / n) || !(o_r < r1 / n)) return fit;
  fit.two_speeds = true;
  fit.deadband_left = o_l, fit.deadband_right = o_r;
  fit.trim = wheels::trimFromSpeedRatio(s * (1 - o_l) / (1 - o_r), params.gain);
  return fit;
}

}  // namespace

StraightRunFit straightRunFit(const std::vector<StraightRun>& runs,
                              const std::vector<int>& accepted,
                              const wheels::KinematicsParams& params) {
  // The lags are taken out through the file's left deadband, then through the one fitted (a
  // deadband 0.01 off moves a duty 0.3 % level by 3e-5).
  StraightRunFit fit = fitTwoSpeeds(runs, accepted, params, params.deadband_left);
  if (fit.two_speeds) {
    const StraightRunFit again = fitTwoSpeeds(runs, accepted, params, fit.deadband_left);
    if (again.two_speeds) fit = again;
  }
  if (!fit.two_speeds) fit.trim = straightRunTrim(runs, accepted, params);
  return fit;
}

double straightRunTrim(const std::vector<StraightRun>& runs, const std::vector<int>& accepted,
                       const wheels::KinematicsParams& params) {
  double left = 0, right = 0;
  int n = 0;
  for (const int i : accepted) {
    if (i < 0 || i >= static_cast<int>(runs.size())) continue;
    const StraightRun& r = runs[static_cast<size_t>(i)];
    if (!r.forward || !(r.mean_left_duty > 0) || !(r.mean_right_duty > 0)) continue;
    left += r.mean_left_duty, right += r.mean_right_duty, ++n;
  }
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  const double u_left = wheels::removeDeadband(left / n, params.deadband_left);
  const double u_right = wheels::removeDeadband(right / n, params.deadband_right);
  if (!(u_left > 0) || !(u_right > 0)) return std::numeric_limits<double>::quiet_NaN();
  return wheels::trimFromSpeedRatio(u_right / u_left, params.gain);
}

double straightTurnPerM(const wheels::KinematicsParams& driven,
                        const wheels::KinematicsParams& truth, double speed_mps,
                        double wheelbase_m) {
  const double w = speed_mps / driven.radius;
  const wheels::WheelSpeeds s =
      wheels::dutiesToSpeeds(truth, wheels::speedsToDuties(driven, {w, w}));
  return 2 * (s.right - s.left) / ((s.right + s.left) * wheelbase_m);
}

TrimRefinement planTrimRefinement(const std::string& path, const std::vector<StraightRun>& runs,
                                  const std::vector<int>& accepted, double max_disagreement) {
  TrimRefinement out;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return out;
  out.params = out.before = wheels::readKinematicsFile(path);
  const StraightRunFit fit = straightRunFit(runs, accepted, out.params);
  if (!std::isfinite(fit.trim)) return out;
  out.compared = true;
  out.file_trim = out.params.trim;
  out.straight_trim = fit.trim;
  out.replace = max_disagreement >= 0 && std::abs(fit.trim - out.file_trim) > max_disagreement;
  if (out.replace) {
    out.params.trim = fit.trim;
    if (fit.two_speeds) {
      out.deadbands = true;
      out.params.deadband_left = fit.deadband_left;
      out.params.deadband_right = fit.deadband_right;
    }
    out.params.validate();
  }
  return out;
}

void writeTrimRefinement(const std::string& path, TrimRefinement& plan) {
  if (!plan.replace) return;
  // In a run the wheel stage wrote this file a moment ago and kept the one from before the run as
  // `.prev`: that one stays (only the trim changes here, and the one replaced is in the result).
  // Without a `.prev`, the file replaced becomes it.
  std::error_code ec;
  AtomicWriteOptions write;
  if (std::filesystem::exists(path + ".prev", ec)) write.backup_suffix.clear();
  writeFileAtomically(path, wheels::kinematicsYaml(plan.params, wheels::kinematicsTimeUtcNow()),
                      write);
  plan.written = true;
}

TrimRefinement refineKinematicsTrim(const std::string& path, const std::vector<StraightRun>& runs,
                                    const std::vector<int>& accepted, double max_disagreement) {
  TrimRefinement t = planTrimRefinement(path, runs, accepted, max_disagreement);
  writeTrimRefinement(path, t);
  return t;
}

namespace {

/// The wheel stage's hops, taken as straight, turned as its kinematics leave a robot turning: the
/// camera's extrinsics it wrote with their sensitivity to that turn are corrected for it. The
/// trim and the odometry file stand whatever happens here: a file that cannot be corrected (no
/// intrinsics file, another camera's P, one that cannot be read) is left as it is, and the DONE
/// text says why.
void correctExtrinsicsForTheHops(const StageOutput& output, const TrimRefinement& t,
                                 double wheelbase_m, StageResult* r) {
  const std::string path = extrinsics::extrinsicsPath(output.calibration_root, output.veh);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return;
  try {
    YamlMap y = YamlMap::loadFile(path);
    if (!y.has(extrinsics::kYawPerTurnKey) || !y.has(extrinsics::kStraightSpeedKey)) return;
    const double turn_per_m = straightTurnPerM(
        t.before, t.params, y.required<double>(extrinsics::kStraightSpeedKey), wheelbase_m);
    const std::string intrinsics =
        camera::cameraIntrinsicsPath(output.calibration_root, output.veh);
    const extrinsics::StraightTurnCorrection c = extrinsics::correctForStraightTurn(
        path, turn_per_m, extrinsics::loadRectification(intrinsics),
        "the floor tags of the wheel stage, its hops' turn from the odometry stage's trim "
        "(intrinsics " + intrinsics + ")",
        utcNowIso8601());
    if (!c.corrected) return;
    r->figures.push_back({"extrinsics_yaw_change_rad", c.yaw_change_rad});
    const std::string said = "the camera's yaw in " + path + " moved by " +
                             formatNumber(c.yaw_change_rad * 180 / M_PI, 3) +
                             " deg (the wheel stage's hops turned " +
                             formatNumber(turn_per_m * 180 / M_PI, 3) + " deg per metre)";
    r->log += "; " + said;
    r->text += "; " + said;
  } catch (const Error& e) {
    const std::string said =
        "the camera's extrinsics in " + path + " were not corrected for the new trim: " + e.what();
    r->log += "; " + said;
    r->text += "; " + said;
  }
}

}  // namespace

StageResult finishUahStage(const StageOutput& output, const UahResult& result,
                           const std::vector<UahTurn>& turns, double elapsed_s,
                           const std::vector<StraightRun>& straight_runs,
                           double max_trim_disagreement) {
  const std::string path = wheels::kinematicsPath(output.calibration_root, output.veh);
  TrimRefinement t;
  if (max_trim_disagreement >= 0)
    t = planTrimRefinement(path, straight_runs, result.straight.accepted_runs,
                           max_trim_disagreement);
  StageResult r = writeUahStageFile(output, result, turns, elapsed_s);
  if (!t.compared) return r;
  writeTrimRefinement(path, t);
  r.figures.push_back({"straight_run_trim", t.straight_trim});
  r.figures.push_back({"kinematics_trim", t.file_trim});
  r.log += "; the straight runs' trim " + formatNumber(t.straight_trim, 5) +
           ", the wheel stage's " + formatNumber(t.file_trim, 5) +
           (t.written ? " (replaced in " + path + ")"
                      : " (kept, within " + formatNumber(max_trim_disagreement, 3) + ")");
  if (t.written) {
    r.text = "wrote " + r.file + "; the straight runs' trim " + formatNumber(t.straight_trim, 5) +
             " replaced the wheel stage's " + formatNumber(t.file_trim, 5) + " in " + path +
             " (they differ by more than max_trim_disagreement " +
             formatNumber(max_trim_disagreement, 3) +
             ": floor tags laid turned bias the tags' trim)";
    correctExtrinsicsForTheHops(output, t, result.calibrated.wheelbase_m, &r);
  }
  return r;
}

StageResult UahRun::finish(const StageOutput& output) {
  return finishUahStage(output, result_, turns_, elapsedS(), straight_runs_,
                        options_.max_trim_disagreement);
}

}  // namespace odometry
}  // namespace autocal
