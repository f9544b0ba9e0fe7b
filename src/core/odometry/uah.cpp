#include "autocal/odometry/uah.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace odometry {

namespace {

bool validRange(double r, const RoundDetectionOptions& o) {
  return std::isfinite(r) && r >= o.min_range_m && r <= o.max_range_m;
}

// Sub-sample position of a peak at index k: the vertex of the parabola through k−1, k, k+1.
double parabolicPeak(const std::vector<double>& r, int k) {
  if (k <= 0 || k + 1 >= static_cast<int>(r.size())) return k;
  const double a = r[k - 1], b = r[k], c = r[k + 1];
  if (!std::isfinite(a) || !std::isfinite(c)) return k;
  const double denom = a - 2.0 * b + c;
  if (!(denom < 0.0)) return k;
  const double d = 0.5 * (a - c) / denom;
  return k + std::clamp(d, -0.5, 0.5);
}

int argmaxIn(const std::vector<double>& r, int lo, int hi) {
  int best = -1;
  for (int k = std::max(lo, 0); k <= std::min(hi, static_cast<int>(r.size()) - 1); ++k) {
    if (std::isfinite(r[k]) && (best < 0 || r[k] > r[best])) best = k;
  }
  return best;
}

}  // namespace

void RoundDetectionOptions::validate() const {
  if (!std::isfinite(expected_pulses_per_round) || expected_pulses_per_round < 8.0) {
    throw ConfigError("expected_pulses_per_round must be at least 8, got " +
                      formatNumber(expected_pulses_per_round));
  }
  if (!(window_fraction > 0.0 && window_fraction < 0.5)) {
    throw ConfigError("window_fraction must be in (0, 0.5), got " + formatNumber(window_fraction));
  }
  if (!(max_range_m > min_range_m)) throw ConfigError("max_range_m must exceed min_range_m");
  if (!(max_gap_pulses >= 0.0)) throw ConfigError("max_gap_pulses must be non-negative");
  if (!(min_peak_correlation > 0.0 && min_peak_correlation <= 1.0)) {
    throw ConfigError("min_peak_correlation must be in (0, 1]");
  }
  if (!(max_secondary_ratio > 0.0 && max_secondary_ratio <= 1.0)) {
    throw ConfigError("max_secondary_ratio must be in (0, 1]");
  }
}

std::vector<double> resampleOnPulses(const std::vector<RangeSample>& samples,
                                     const RoundDetectionOptions& options, double* first_pulse) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : samples) {
    if (!std::isfinite(s.pulses)) continue;
    lo = std::min(lo, s.pulses);
    hi = std::max(hi, s.pulses);
  }
  if (!(hi > lo)) throw CalibrationError("the range readings span no encoder pulses");
  const int n = static_cast<int>(std::floor(hi - lo)) + 1;
  std::vector<double> sum(n, 0.0);
  std::vector<int> count(n, 0);
  for (const auto& s : samples) {
    if (!std::isfinite(s.pulses) || !validRange(s.range_m, options)) continue;
    const int i = std::min(n - 1, static_cast<int>(std::floor(s.pulses - lo + 0.5)));
    sum[i] += s.range_m;
    ++count[i];
  }
  std::vector<double> out(n, std::numeric_limits<double>::quiet_NaN());
  int last = -1;
  for (int i = 0; i < n; ++i) {
    if (count[i] == 0) continue;
    out[i] = sum[i] / count[i];
    // Bridge a short gap since the previous filled cell by linear interpolation.
    if (last >= 0 && i - last > 1 && i - last <= options.max_gap_pulses) {
      for (int j = last + 1; j < i; ++j) {
        const double t = static_cast<double>(j - last) / (i - last);
        out[j] = out[last] + t * (out[i] - out[last]);
      }
    }
    last = i;
  }
  *first_pulse = lo;
  return out;
}

std::vector<double> normalizedAutocorrelation(const std::vector<double>& x, int max_lag) {
  const int n = static_cast<int>(x.size());
  double mean = 0.0;
  int valid = 0;
  for (double v : x) {
    if (std::isfinite(v)) {
      mean += v;
      ++valid;
    }
  }
  std::vector<double> r(std::max(0, max_lag + 1), std::numeric_limits<double>::quiet_NaN());
  if (valid == 0) return r;
  mean /= valid;
  std::vector<double> a(n);
  for (int i = 0; i < n; ++i) a[i] = std::isfinite(x[i]) ? x[i] - mean : NAN;
  for (int k = 0; k <= max_lag && k < n; ++k) {
    double sab = 0.0, saa = 0.0, sbb = 0.0;
    int pairs = 0;
    for (int i = 0; i + k < n; ++i) {
      const double p = a[i], q = a[i + k];
      if (std::isnan(p) || std::isnan(q)) continue;
      sab += p * q;
      saa += p * p;
      sbb += q * q;
      ++pairs;
    }
    if (pairs >= 8 && saa > 0.0 && sbb > 0.0) r[k] = sab / std::sqrt(saa * sbb);
  }
  return r;
}

RoundDetection detectWholeRound(const std::vector<RangeSample>& samples,
                                const RoundDetectionOptions& options) {
  options.validate();
  const double nt = options.expected_pulses_per_round;
  double first = 0.0;
  const std::vector<double> x = resampleOnPulses(samples, options, &first);
  const int n = static_cast<int>(x.size());

  RoundDetection det;
  det.valid_fraction = static_cast<double>(std::count_if(x.begin(), x.end(),
                                                         [](double v) { return !std::isnan(v); })) /
                       n;
  det.rounds_covered = n / nt;
  const int lo = static_cast<int>(std::floor(nt * (1.0 - options.window_fraction)));
  const int hi = static_cast<int>(std::ceil(nt * (1.0 + options.window_fraction)));
  // The correlation at a lag of one round needs at least about half a round of overlap.
  if (n < hi + nt / 2) {
    throw CalibrationError("the readings cover " + formatNumber(det.rounds_covered, 3) +
                           " rounds; whole-round detection needs at least " +
                           formatNumber((hi + nt / 2) / nt, 3) + " (turn more rounds)");
  }
  if (det.valid_fraction < 0.5) {
    throw CalibrationError("only " + formatNumber(100 * det.valid_fraction, 3) +
                           " % of the pulse axis has a range reading (dropouts or out of range)");
  }

  // §2.1: the autocorrelation of the range sequence as a function of the pulse lag peaks where
  // the robot has turned exactly one round, since a round brings back the same view.
  const int max_lag = std::min(n - static_cast<int>(nt / 2), static_cast<int>(n - 1));
  const std::vector<double> r = normalizedAutocorrelation(x, max_lag);

  // End of the zero-lag lobe: the first lag where the correlation falls below 0.3. A range that
  // never decorrelates within the window does not vary with heading.
  int lobe_end = -1;
  for (int k = 1; k < lo; ++k) {
    if (std::isfinite(r[k]) && r[k] < 0.3) {
      lobe_end = k;
      break;
    }
  }
  if (lobe_end < 0) {
    throw CalibrationError(
        "the range barely changes as the robot turns (featureless or "
        "circular scene): no whole round can be told apart; place obstacles "
        "at different distances around the robot");
  }

  const int k1 = argmaxIn(r, lo, hi);
  if (k1 < 0) throw CalibrationError("no autocorrelation in the search window");
  det.peak_correlation = r[k1];
  const int secondary = argmaxIn(r, lobe_end, lo - 1);
  if (secondary >= 0) {
    det.secondary_correlation = r[secondary];
    det.secondary_lag_pulses = secondary;
  }
  if (r[k1] < options.min_peak_correlation) {
    throw CalibrationError("weak whole-round peak: correlation " + formatNumber(r[k1], 3) + " < " +
                           formatNumber(options.min_peak_correlation, 3) +
                           " (scene too noisy, too far or changing while turning)");
  }
  if (secondary >= 0 && r[secondary] >= options.max_secondary_ratio * r[k1]) {
    throw CalibrationError("ambiguous whole round: the range signal repeats after " +
                           formatNumber(secondary, 4) + " pulses (" +
                           formatNumber(secondary / nt, 3) + " of a round, correlation " +
                           formatNumber(r[secondary], 3) + " against " + formatNumber(r[k1], 3) +
                           " at the round): the scene is symmetric or periodic; make it irregular");
  }
  if (k1 == lo || k1 == hi) {
    throw CalibrationError("the autocorrelation peak lies on the edge of the search window (" +
                           formatNumber(k1, 5) + " pulses, window " + formatNumber(lo, 5) + ".." +
                           formatNumber(hi, 5) +
                           "): the expected pulses per round are wrong or the scene misleads");
  }
  // Refine below one pulse: vertex of the parabola through the peak and its neighbours.
  det.single_round_pulses = parabolicPeak(r, k1);

  // Peaks at m rounds fall at m·N; a line through the origin fitted to them divides the
  // sub-pulse error of one peak by about m.
  double smp = det.single_round_pulses, smm = 1.0;
  det.rounds_used = 1;
  if (options.use_multiple_rounds) {
    for (int m = 2;; ++m) {
      const double centre = m * det.single_round_pulses;
      if (centre + 3 > max_lag) break;
      const int km = argmaxIn(r, static_cast<int>(std::floor(centre)) - 3,
                              static_cast<int>(std::ceil(centre)) + 3);
      if (km < 0 || r[km] < options.min_peak_correlation) break;
      smp += m * parabolicPeak(r, km);
      smm += static_cast<double>(m) * m;
      ++det.rounds_used;
    }
  }
  det.pulses_per_round = smp / smm;
  return det;
}

EdEstimate estimateEd(const std::vector<double>& right_pulses_left_stopped,
                      const std::vector<double>& left_pulses_right_stopped,
                      double max_relative_spread) {
  auto stats = [](const std::vector<double>& v, const char* what, double* mean, double* spread) {
    if (v.empty()) throw InputError(std::string("no pulses-per-round values for ") + what);
    for (double x : v) {
      if (!std::isfinite(x) || x <= 0.0) {
        throw InputError(std::string("pulses per round must be positive (") + what + ")");
      }
    }
    *mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    const auto mm = std::minmax_element(v.begin(), v.end());
    *spread = (*mm.second - *mm.first) / *mean;
  };
  EdEstimate e;
  stats(right_pulses_left_stopped, "the pivot on the stopped left wheel", &e.right_pulses_per_round,
        &e.right_relative_spread);
  stats(left_pulses_right_stopped, "the pivot on the stopped right wheel", &e.left_pulses_per_round,
        &e.left_relative_spread);
  if (e.right_relative_spread > max_relative_spread ||
      e.left_relative_spread > max_relative_spread) {
    throw CalibrationError("the pivot experiments disagree: spread " +
                           formatNumber(100 * e.right_relative_spread, 3) + " % (left stopped), " +
                           formatNumber(100 * e.left_relative_spread, 3) +
                           " % (right stopped), limit " +
                           formatNumber(100 * max_relative_spread, 3) + " % (wheel slipping?)");
  }
  // §2.2: 2π·b' = N_R·c_R = N_L·c_L  ⇒  Ed = D_R/D_L = c_R/c_L = N_L/N_R.
  e.Ed = e.left_pulses_per_round / e.right_pulses_per_round;
  return e;
}

void StraightRunOptions::validate() const {
  if (!(max_heading_deviation_rad > 0.0 && max_heading_deviation_rad < M_PI / 4)) {
    throw ConfigError("max_heading_deviation_rad must be in (0, π/4)");
  }
  if (!(max_shortening > 0.0 && max_shortening < 0.05)) {
    throw ConfigError("max_shortening must be in (0, 0.05)");
  }
  if (!(max_disagreement > 0.0 && max_disagreement < 0.2)) {
    throw ConfigError("max_disagreement must be in (0, 0.2)");
  }
}

void PulseLine::add(double left_pulses, double right_pulses) {
  n += 1, r += right_pulses, l += left_pulses;
  rr += right_pulses * right_pulses, rl += right_pulses * left_pulses;
}

double PulseLine::leftLag(double Ed) const {
  const double var = n * rr - r * r;
  if (n < 3 || !(var > 0) || !(Ed > 0)) return 0.0;
  return 1 - (n * rl - r * l) / var / Ed;
}

MmPerPulseEstimate estimateMmPerPulse(const std::vector<StraightRun>& runs,
                                      const StraightRunOptions& options) {
  options.validate();
  if (runs.empty()) throw InputError("no straight runs");
  MmPerPulseEstimate e;
  std::vector<int> kept;  // within the heading bound
  for (size_t i = 0; i < runs.size(); ++i) {
    const StraightRun& run = runs[i];
    if (!(run.length_m > 0.0) || !(run.right_pulses > 0.0) || !std::isfinite(run.length_m) ||
        !std::isfinite(run.right_pulses)) {
      throw InputError("straight run " + std::to_string(i) +
                       ": length and pulses must be positive numbers");
    }
    // §2.3: the start-to-end distance stands for the wheel's path only while the heading stays
    // close to the initial one; reject the run otherwise, or when its excursions cost the
    // distance more than a steady max_shortening would.
    if (!(std::abs(run.max_heading_deviation_rad) <= options.max_heading_deviation_rad)) {
      e.rejected_runs.push_back(static_cast<int>(i));
      e.rejection_reasons.push_back(
          "run " + std::to_string(i) + ": heading deviated " +
          formatNumber(run.max_heading_deviation_rad * 180 / M_PI, 3) + " deg > " +
          formatNumber(options.max_heading_deviation_rad * 180 / M_PI, 3) + " deg");
      continue;
    }
    if (!(run.shortening <= options.max_shortening)) {
      e.rejected_runs.push_back(static_cast<int>(i));
      e.rejection_reasons.push_back(
          "run " + std::to_string(i) + ": its heading's excursions shortened it by " +
          formatNumber(100 * run.shortening, 3) + " % against the wheel's path > " +
          formatNumber(100 * options.max_shortening, 3) + " %");
      continue;
    }
    kept.push_back(static_cast<int>(i));
  }
  // §2.3: c_R = distance / N_R. A run loses distance against its pulses, never gains it: the
  // largest c_R of the kept runs is the reference the others must agree with.
  const auto perPulse = [&](int i) { return runs[i].length_m / runs[i].right_pulses; };
  int largest = -1;
  for (int i : kept)
    if (largest < 0 || perPulse(i) > perPulse(largest)) largest = i;
  double sum = 0.0;
  for (int i : kept) {
    const double short_by = 1 - perPulse(i) / perPulse(largest);
    if (short_by > options.max_disagreement) {
      e.rejected_runs.push_back(i);
      e.rejection_reasons.push_back(
          "run " + std::to_string(i) + ": " + formatNumber(100 * short_by, 3) +
          " % less distance per pulse than run " + std::to_string(largest) + " (limit " +
          formatNumber(100 * options.max_disagreement, 3) +
          " %): it lost distance on the way (a wheel slipped or rubbed a wall, or the path "
          "curved)");
      continue;
    }
    e.accepted_runs.push_back(i);
    sum += perPulse(i);
  }
  if (e.accepted_runs.empty()) {
    std::string why;
    for (const auto& r : e.rejection_reasons) why += "; " + r;
    throw CalibrationError("every straight run was rejected" + why);
  }
  e.right_m_per_pulse = sum / e.accepted_runs.size();
  return e;
}

double maxHeadingDeviationRad(const std::vector<std::pair<double, double>>& cumulative_pulses,
                              const DiffDriveParams& params) {
  if (cumulative_pulses.size() < 2) return 0.0;
  DeadReckoning dr(params);
  double worst = 0.0;
  for (size_t i = 1; i < cumulative_pulses.size(); ++i) {
    dr.addPulses(cumulative_pulses[i].first - cumulative_pulses[i - 1].first,
                 cumulative_pulses[i].second - cumulative_pulses[i - 1].second);
    worst = std::max(worst, std::abs(dr.pose().yaw_rad));
  }
  return worst;
}

double pathShortening(const std::vector<std::pair<double, double>>& cumulative_pulses,
                      const DiffDriveParams& params) {
  if (cumulative_pulses.size() < 2) return 0.0;
  DeadReckoning dr(params);
  for (size_t i = 1; i < cumulative_pulses.size(); ++i) {
    dr.addPulses(cumulative_pulses[i].first - cumulative_pulses[i - 1].first,
                 cumulative_pulses[i].second - cumulative_pulses[i - 1].second);
  }
  if (!(dr.distance_m() > 0.0)) return 0.0;
  return 1.0 - std::hypot(dr.pose().x_m, dr.pose().y_m) / dr.distance_m();
}

WheelbaseEstimate estimateWheelbase(double spin_pulses_per_round,
                                    double pivot_right_pulses_per_round, double left_m_per_pulse,
                                    double right_m_per_pulse) {
  for (double v :
       {spin_pulses_per_round, pivot_right_pulses_per_round, left_m_per_pulse, right_m_per_pulse}) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw InputError("wheelbase: pulses per round and distances per pulse must be positive");
    }
  }
  WheelbaseEstimate w;
  w.wheelbase_m = spin_pulses_per_round * (left_m_per_pulse + right_m_per_pulse) / (2.0 * M_PI);
  w.pivot_radius_m = pivot_right_pulses_per_round * right_m_per_pulse / (2.0 * M_PI);
  w.pivot_to_spin_ratio = pivot_right_pulses_per_round / spin_pulses_per_round;
  return w;
}

OdometryCalibration UahResult::toOdometryCalibration(const std::string& vehicle) const {
  OdometryCalibration c;
  c.method = "uah";
  c.vehicle = vehicle;
  c.Ed = ed.Ed;
  c.wheelbase_nominal_m = nominal.wheelbase_m;
  c.wheelbase_m = calibrated.wheelbase_m;
  c.Eb = calibrated.wheelbase_m / nominal.wheelbase_m;
  c.left_pulse_factor = calibrated.left_m_per_pulse / nominal.left_m_per_pulse;
  c.right_pulse_factor = calibrated.right_m_per_pulse / nominal.right_m_per_pulse;
  c.left_m_per_pulse = calibrated.left_m_per_pulse;
  c.right_m_per_pulse = calibrated.right_m_per_pulse;
  c.inputs = {{"right_pulses_per_round_left_stopped", formatNumber(ed.right_pulses_per_round)},
              {"left_pulses_per_round_right_stopped", formatNumber(ed.left_pulses_per_round)},
              {"straight_runs_accepted", std::to_string(straight.accepted_runs.size())},
              {"straight_runs_rejected", std::to_string(straight.rejected_runs.size())},
              {"pivot_radius_m", formatNumber(wheelbase.pivot_radius_m)},
              {"pivot_to_spin_ratio", formatNumber(wheelbase.pivot_to_spin_ratio)}};
  return c;
}

UahResult computeUah(const DiffDriveParams& nominal,
                     const std::vector<double>& right_pulses_left_stopped,
                     const std::vector<double>& left_pulses_right_stopped,
                     const std::vector<StraightRun>& straight_runs, double spin_pulses_per_round,
                     const StraightRunOptions& straight_options) {
  nominal.validate();
  UahResult r;
  r.nominal = nominal;
  r.ed = estimateEd(right_pulses_left_stopped, left_pulses_right_stopped);
  r.straight = estimateMmPerPulse(straight_runs, straight_options);
  r.calibrated.right_m_per_pulse = r.straight.right_m_per_pulse;
  // The right wheel is the reference (§2.3): c_L = c_R/Ed.
  r.calibrated.left_m_per_pulse = r.straight.right_m_per_pulse / r.ed.Ed;
  r.wheelbase = estimateWheelbase(spin_pulses_per_round, r.ed.right_pulses_per_round,
                                  r.calibrated.left_m_per_pulse, r.calibrated.right_m_per_pulse);
  r.calibrated.wheelbase_m = r.wheelbase.wheelbase_m;
  return r;
}

}  // namespace odometry
}  // namespace autocal
