// Each wheel's duty → speed line from the wheel stage's drives (see motor_fit.h).
#include "autocal/wheels/motor_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace autocal {
namespace wheels {

namespace {

constexpr double kMinSpread = 0.03;  ///< duties closer than this are one duty for the line
constexpr double kMaxOffset = 0.6;   ///< a deadband beyond this is a failed fit

using Points = std::vector<MotorFitter::Point>;

/// One line through every point, whatever its direction.
void fitLine(const Points& pts, MotorFit& out) {
  double lo = 1e9, hi = -1e9, m = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& p : pts) {
    const double w = p.weight;
    lo = std::min(lo, p.duty), hi = std::max(hi, p.duty);
    m += w, sx += w * p.duty, sy += w * p.rate, sxx += w * p.duty * p.duty,
        sxy += w * p.duty * p.rate;
  }
  if (hi - lo < kMinSpread) return;  // one duty: the line is not determined
  const double a = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  const double b = (sy - a * sx) / m;
  if (!(a > 0)) return;
  const double offset = -b / a;
  if (!(offset >= 0 && offset < kMaxOffset)) return;
  out = {true, a, a, offset, static_cast<int>(pts.size()), false};
}

/// Each direction's slope through the offset `offset` (weighted least squares through the point
/// (offset, 0)), and the weighted squared residual; false when a direction's points do not lie
/// above the offset.
bool slopesAt(const Points& pts, double offset, double slope[2], double* sse) {
  double sxx[2] = {0, 0}, sxy[2] = {0, 0}, syy[2] = {0, 0};
  for (const auto& p : pts) {
    const int d = p.backward ? 1 : 0;
    const double x = p.duty - offset;
    if (x <= 0) return false;
    sxx[d] += p.weight * x * x, sxy[d] += p.weight * x * p.rate, syy[d] += p.weight * p.rate * p.rate;
  }
  *sse = 0;
  for (int d = 0; d < 2; ++d) {
    slope[d] = sxx[d] > 0 ? sxy[d] / sxx[d] : 0.0;
    if (sxx[d] > 0) *sse += syy[d] - sxy[d] * sxy[d] / sxx[d];
  }
  return true;
}

/// A slope per direction through one offset, when some direction's points span two duties: the
/// offset that leaves the least squared residual (a scan, then a golden-section search).
bool fitPerDirection(const Points& pts, MotorFit& out) {
  double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
  for (const auto& p : pts) {
    const int d = p.backward ? 1 : 0;
    lo[d] = std::min(lo[d], p.duty), hi[d] = std::max(hi[d], p.duty);
  }
  if (hi[0] - lo[0] < kMinSpread && hi[1] - lo[1] < kMinSpread) return false;
  const double top = std::min({lo[0], lo[1], kMaxOffset}) - 1e-6;
  double slope[2], sse = 0, best = -1, best_sse = 0;
  constexpr double kStep = 0.002;
  for (double o = 0; o < top; o += kStep) {
    if (slopesAt(pts, o, slope, &sse) && (best < 0 || sse < best_sse)) best = o, best_sse = sse;
  }
  if (best < 0) return false;
  double a = std::max(0.0, best - kStep), b = std::min(top, best + kStep);
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  for (int i = 0; i < 40; ++i) {
    const double c = b - g * (b - a), d = a + g * (b - a);
    double sc = 0, sd = 0;
    const bool okc = slopesAt(pts, c, slope, &sc), okd = slopesAt(pts, d, slope, &sd);
    if (!okd || (okc && sc < sd)) b = d; else a = c;
  }
  const double offset = 0.5 * (a + b);
  if (!slopesAt(pts, offset, slope, &sse)) return false;
  const bool forward = lo[0] < 1e9, backward = lo[1] < 1e9;
  const double f = forward ? slope[0] : slope[1], r = backward ? slope[1] : slope[0];
  if (!(f > 0 && r > 0 && offset >= 0 && offset < kMaxOffset)) return false;
  out = {true, f, r, offset, static_cast<int>(pts.size()), true};
  return true;
}

void fit(const Points& pts, MotorFit& out) {
  if (!fitPerDirection(pts, out)) fitLine(pts, out);
}

double residual(const MotorFitter::Point& p, const MotorFit& f) {
  const double slope = p.backward ? f.backward_slope : f.slope;
  return std::abs(p.rate - slope * (p.duty - f.offset)) / std::max(p.rate, 1e-9);
}

/// The slope [ticks/s] of a wheel's readings (time, count) turning at a steady speed, each count
/// the angle quantised to a tick, [count, count + 1) in ticks: the middle of the slopes of the
/// lines that pass through every reading's interval; NaN when no line does (the speed varied).
/// Least squares is no estimate here: at a speed near a whole number of ticks per reading the
/// quantisation errors do not average out but drift slowly (a saw tooth over the drive), and
/// two drives at the same duty differed by 0.16 % in rate (a deadband 0.0004 off).
double quantisedSlope(const std::vector<std::array<double, 2>>& readings, double guess) {
  if (readings.size() < 5 || !(std::abs(guess) > 0)) return std::nan("");
  double mean_t = 0;
  for (const auto& r : readings) mean_t += r[0] / static_cast<double>(readings.size());
  // The room a slope b leaves the intercept: the lowest interval top less the highest bottom,
  // each less b·t. Concave in b (a minimum of lines less a maximum of lines).
  const auto room = [&](double b) {
    double bottom = -std::numeric_limits<double>::infinity();
    double top = std::numeric_limits<double>::infinity();
    for (const auto& r : readings) {
      const double at = b * (r[0] - mean_t);
      bottom = std::max(bottom, r[1] - at);
      top = std::min(top, r[1] + 1 - at);
    }
    return top - bottom;
  };
  double lo = guess - 0.03 * std::abs(guess), hi = guess + 0.03 * std::abs(guess);
  for (int i = 0; i < 80; ++i) {  // the peak
    const double a = lo + (hi - lo) / 3, b = hi - (hi - lo) / 3;
    if (room(a) < room(b)) lo = a; else hi = b;
  }
  const double peak = 0.5 * (lo + hi);
  if (room(peak) < 0) return std::nan("");
  const auto edge = [&](double inside, double outside) {  // where the room closes
    if (room(outside) >= 0) return outside;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (inside + outside);
      (room(mid) >= 0 ? inside : outside) = mid;
    }
    return 0.5 * (inside + outside);
  };
  const double span = 0.03 * std::abs(guess);
  return 0.5 * (edge(peak, peak - span) + edge(peak, peak + span));
}

}  // namespace

WheelDuties meanDuties(const DriveRecord& drive, double t0_s, double t1_s) {
  WheelDuties now{std::abs(drive.duties.left), std::abs(drive.duties.right)};
  if (drive.commands.empty() || !(t1_s > t0_s)) return now;
  // Weighted as the least-squares slope of the ticks over [t0, t1] weighs the speed: by
  // (t − t0)(t1 − t), whose integral from t0 is T·u²/2 − u³/3 (u = t − t0, T = t1 − t0).
  const double T = t1_s - t0_s;
  const auto weight_to = [&](double t) {
    const double u = std::clamp(t - t0_s, 0.0, T);
    return T * u * u / 2 - u * u * u / 3;
  };
  double sum_left = 0, sum_right = 0, t = t0_s;
  for (const auto& c : drive.commands) {
    if (c[0] >= t1_s) break;
    if (c[0] > t) {
      const double w = weight_to(c[0]) - weight_to(t);
      sum_left += now.left * w, sum_right += now.right * w;
      t = c[0];
    }
    now = {std::abs(c[1]), std::abs(c[2])};
  }
  const double w = weight_to(t1_s) - weight_to(t);
  sum_left += now.left * w, sum_right += now.right * w;
  const double total = T * T * T / 6;
  return {sum_left / total, sum_right / total};
}

const char* wheelsWithoutLine(const MotorFit& left, const MotorFit& right) {
  if (!left.valid && !right.valid) return "left and right wheels";
  if (!left.valid) return "left wheel";
  return right.valid ? "" : "right wheel";
}

void MotorFitter::addDrive(const DriveRecord& drive, int ticks_per_revolution) {
  // The fit is frozen after fit_drives drives: the trim estimator measures k against the offsets
  // the drives compensate, and offsets that kept moving by a few 1e-4 (each a few 0.1 % of the
  // wheel speed) would keep moving the k it converges to.
  if (frozen() || ticks_per_revolution <= 0) return;
  // Steady rate of each wheel: least squares of ticks against time after the motors' lag.
  const double t0 = drive.start_s + options_.motor_settle_s, t1 = drive.end_s;
  if (t1 - t0 < options_.min_fit_window_s) return;  // a short drive's rate is too coarse
  // Each wheel's rate from its own readings: a sample whose count of that wheel changed from the
  // sample before came from that wheel's message, at its stamp. The other wheel's count in it is
  // the last one that arrived, up to an encoder period older than the stamp, and how the two
  // wheels' messages interleave differs between a live run and its replay.
  // The rate: the lines through every reading's tick (quantisedSlope), else least squares.
  const auto rate = [&](int wheel, double* out) {
    double n = 0, st = 0, stt = 0, sx = 0, stx = 0;
    std::vector<std::array<double, 2>> readings;
    for (size_t i = 1; i < drive.samples.size(); ++i) {
      const auto& s = drive.samples[i];
      if (s[0] < t0 || s[0] > t1 || s[wheel] == drive.samples[i - 1][wheel]) continue;
      n += 1, st += s[0], stt += s[0] * s[0], sx += s[wheel], stx += s[0] * s[wheel];
      readings.push_back({s[0], s[wheel]});
    }
    const double den = n * stt - st * st;
    if (n < 5 || den <= 0) return false;
    const double least_squares = (n * stx - st * sx) / den;
    const double quantised = quantisedSlope(readings, least_squares);
    *out = std::abs(2 * M_PI / ticks_per_revolution *
                    (std::isfinite(quantised) ? quantised : least_squares));
    return true;
  };
  double rate_left = 0, rate_right = 0;
  if (!rate(1, &rate_left) || !rate(2, &rate_right)) return;
  // A rate's variance from a window of length T falls as 1/T^3 (quantised ticks, uniform
  // samples): the short first drives weigh little next to the long ones.
  const double weight = std::pow(t1 - t0, 3);
  // A steered drive's duties varied: its rate answers their mean over the window, once they have
  // settled.
  const WheelDuties duties = meanDuties(drive, t0, t1);
  const double mid = 0.5 * (t0 + t1);
  const WheelDuties early = meanDuties(drive, t0, mid), late = meanDuties(drive, mid, t1);
  if (std::abs(late.left - early.left) > options_.max_duty_trend ||
      std::abs(late.right - early.right) > options_.max_duty_trend)
    return;
  points_left_.push_back({duties.left, rate_left, weight, drive.backward});
  points_right_.push_back({duties.right, rate_right, weight, drive.backward});
  // Beyond the paper: a drive whose rate lies off the line of the others by more than
  // max_fit_residual (a bump, a slipping wheel, a command that came late) is dropped from both
  // wheels' fits, the worst first, while at least four drives remain.
  while (true) {
    left_ = right_ = MotorFit();
    fit(points_left_, left_);
    fit(points_right_, right_);
    if (!left_.valid || !right_.valid || points_left_.size() <= 4) break;
    size_t worst = 0;
    double worst_residual = 0;
    for (size_t i = 0; i < points_left_.size(); ++i) {
      const double r =
          std::max(residual(points_left_[i], left_), residual(points_right_[i], right_));
      if (r > worst_residual) worst_residual = r, worst = i;
    }
    if (worst_residual <= options_.max_fit_residual) break;
    points_left_.erase(points_left_.begin() + worst);
    points_right_.erase(points_right_.begin() + worst);
  }
}

}  // namespace wheels
}  // namespace autocal
