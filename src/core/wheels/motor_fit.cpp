// Each wheel's duty → speed line from the wheel stage's drives (see motor_fit.h).
#include "autocal/wheels/motor_fit.h"

#include <algorithm>
#include <cmath>

namespace autocal {
namespace wheels {

namespace {

void fitLine(const std::vector<std::array<double, 3>>& pts, MotorFit& out) {
  double lo = 1e9, hi = -1e9, m = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& p : pts) {
    const double w = p[2];
    lo = std::min(lo, p[0]), hi = std::max(hi, p[0]);
    m += w, sx += w * p[0], sy += w * p[1], sxx += w * p[0] * p[0], sxy += w * p[0] * p[1];
  }
  if (hi - lo < 0.03) return;  // one duty: the line is not determined
  const double a = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  const double b = (sy - a * sx) / m;
  if (!(a > 0)) return;
  const double offset = -b / a;
  if (!(offset >= 0 && offset < 0.6)) return;
  out = {true, a, offset, static_cast<int>(pts.size())};
}

double residual(const std::array<double, 3>& p, const MotorFit& f) {
  return std::abs(p[1] - f.slope * (p[0] - f.offset)) / std::max(p[1], 1e-9);
}

}  // namespace

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
  const auto rate = [&](int wheel, double* out) {
    double n = 0, st = 0, stt = 0, sx = 0, stx = 0;
    for (size_t i = 1; i < drive.samples.size(); ++i) {
      const auto& s = drive.samples[i];
      if (s[0] < t0 || s[0] > t1 || s[wheel] == drive.samples[i - 1][wheel]) continue;
      n += 1, st += s[0], stt += s[0] * s[0], sx += s[wheel], stx += s[0] * s[wheel];
    }
    const double den = n * stt - st * st;
    if (n < 5 || den <= 0) return false;
    *out = std::abs(2 * M_PI / ticks_per_revolution * (n * stx - st * sx) / den);
    return true;
  };
  double rate_left = 0, rate_right = 0;
  if (!rate(1, &rate_left) || !rate(2, &rate_right)) return;
  // A rate's variance from a window of length T falls as 1/T^3 (quantised ticks, uniform
  // samples): the short first drives weigh little next to the long ones.
  const double weight = std::pow(t1 - t0, 3);
  points_left_.push_back({std::abs(drive.duties.left), rate_left, weight});
  points_right_.push_back({std::abs(drive.duties.right), rate_right, weight});
  // Beyond the paper: a drive whose rate lies off the line of the others by more than
  // max_fit_residual (a bump, a slipping wheel, a command that came late) is dropped from both
  // wheels' fits, the worst first, while at least four drives remain.
  while (true) {
    left_ = right_ = MotorFit();
    fitLine(points_left_, left_);
    fitLine(points_right_, right_);
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
