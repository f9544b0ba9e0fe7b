#include "autocal/wheels/trim_estimator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace wheels {

void TrimEstimatorOptions::validate() const {
  if (!(initial_ratio > 0.2 && initial_ratio < 5))
    throw ConfigError("initial_ratio: must be within (0.2, 5)");
  if (!(min_update > 0 && min_update < 0.1))
    throw ConfigError("min_update: must be within (0, 0.1)");
  if (ignored_to_converge < 1) throw ConfigError("ignored_to_converge: must be >= 1");
  if (!(damping > 0 && damping <= 1)) throw ConfigError("damping: must be within (0, 1]");
  if (!(full_step_above >= 0)) throw ConfigError("full_step_above: must be >= 0");
  if (!(max_measured_deviation > 0)) throw ConfigError("max_measured_deviation: must be > 0");
  if (max_rejected_in_a_row < 1) throw ConfigError("max_rejected_in_a_row: must be >= 1");
  if (max_iterations < ignored_to_converge)
    throw ConfigError("max_iterations: must be >= ignored_to_converge");
  if (mean_of_drives < 0) throw ConfigError("mean_of_drives: must be >= 0");
  if (mean_of_drives == 1) throw ConfigError("mean_of_drives: must be 0 (off) or >= 2");
  if (!(max_mean_error > 0)) throw ConfigError("max_mean_error: must be > 0");
  if (more_drives_for_mean < 0) throw ConfigError("more_drives_for_mean: must be >= 0");
  if (!(max_ratio_deviation > 0)) throw ConfigError("max_ratio_deviation: must be > 0");
  if (!(wheel_radius_m > 0)) throw ConfigError("wheel_radius_m: must be > 0 [m]");
  if (!(wheelbase_m > 0)) throw ConfigError("wheelbase_m: must be > 0 [m]");
}

TrimEstimator::TrimEstimator(const TrimEstimatorOptions& options)
    : options_(options), ratio_(options.initial_ratio) {
  options_.validate();
}

const TrimIteration& TrimEstimator::addDrive(double delta_theta_rad, double left_angle_rad) {
  if (!std::isfinite(delta_theta_rad) || !std::isfinite(left_angle_rad) || left_angle_rad <= 0) {
    throw InputError("a drive needs a finite heading change and a positive left wheel angle, got " +
                     formatNumber(delta_theta_rad, 4) + " rad and " +
                     formatNumber(left_angle_rad, 4) + " rad");
  }
  if (converged_) throw CalibrationError("the wheel calibration has already converged");
  TrimIteration it;
  it.ratio_before = ratio_;
  it.delta_theta_rad = delta_theta_rad;
  it.left_angle_rad = left_angle_rad;
  // Paper 000 §3.4, eq. (3)-(4): Δθ = R(c·k − 1)φ_l/L, the true speed factor c·k of this drive.
  const double actual_factor =
      1.0 + delta_theta_rad * options_.wheelbase_m / (options_.wheel_radius_m * left_angle_rad);
  it.k_i = actual_factor;
  if (!(actual_factor > 0) || std::abs(actual_factor - 1.0) > options_.max_measured_deviation) {
    it.rejected = true;
    ++rejected_in_a_row_;
  } else {
    rejected_in_a_row_ = 0;
    // Straight needs c·k' = 1: k' = k/k_i. The paper moves k by (k_i − 1)/2 of the way.
    const double target = ratio_ / actual_factor;
    const double gain =
        std::abs(actual_factor - 1.0) >= options_.full_step_above ? 1.0 : options_.damping;
    const double step = gain * (target - ratio_);
    if (std::abs(step) < options_.min_update) {
      it.ignored = true;
      ++ignored_in_a_row_;
    } else {
      ignored_in_a_row_ = 0;
      it.step = step;
      ratio_ += step;
    }
  }
  it.ratio_after = ratio_;
  history_.push_back(it);
  if (ignored_in_a_row_ >= options_.ignored_to_converge) {
    // Beyond the paper: each ignored drive's correction is below E, but together they still carry
    // the residual they agree on; the result is the mean of what they measured.
    double sum = 0;
    for (int i = 0; i < ignored_in_a_row_; ++i) {
      const TrimIteration& d = history_[history_.size() - 1 - i];
      sum += d.ratio_before / d.k_i;
    }
    ratio_ = sum / ignored_in_a_row_;
    history_.back().ratio_after = ratio_;
    converged_ = true;
  }
  if (rejected_in_a_row_ >= options_.max_rejected_in_a_row) {
    throw CalibrationError(std::to_string(rejected_in_a_row_) +
                           " drives in a row measured an implausible heading change (last k_i " +
                           formatNumber(actual_factor, 4) +
                           "): tags mis-detected or the robot slipped");
  }
  const double d = options_.max_ratio_deviation;
  if (ratio_ > 1 + d || ratio_ < 1 / (1 + d)) {
    throw CalibrationError("the wheel ratio diverged to " + formatNumber(ratio_, 4) + " (allowed " +
                           formatNumber(1 / (1 + d), 4) + ".." + formatNumber(1 + d, 4) + ")");
  }
  if (!converged_ && iterations() >= options_.max_iterations) {
    double mean = 0, error = 0;
    const int limit = options_.max_iterations +
                      (options_.mean_of_drives > 0 ? options_.more_drives_for_mean : 0);
    if (meanOfLastDrives(&mean, &error)) {
      ratio_ = mean;
      history_.back().ratio_after = ratio_;
      converged_ = true;
    } else if (iterations() >= limit) {
      throw CalibrationError(
          "the wheel ratio did not converge in " + std::to_string(iterations()) + " drives (k " +
          formatNumber(ratio_, 4) + ", last update " +
          formatNumber(history_.back().step, 4) +
          (options_.mean_of_drives > 0 ? "; the last drives' mean is ±" + formatNumber(error, 2) +
                                             " sure, for at most ±" +
                                             formatNumber(options_.max_mean_error, 2) +
                                             ": the heading scatters from drive to drive"
                                       : "") +
          ")");
    }
  }
  return history_.back();
}

bool TrimEstimator::meanOfLastDrives(double* mean, double* standard_error) const {
  // The window grows by each drive beyond max_iterations (its standard error falls as 1/√n), over
  // the plausible drives there are; mean_of_drives of them at least.
  const int window = options_.mean_of_drives + std::max(0, iterations() - options_.max_iterations);
  std::vector<double> ratios;  // the latest first
  for (auto it = history_.rbegin();
       it != history_.rend() && static_cast<int>(ratios.size()) < window; ++it) {
    if (!it->rejected) ratios.push_back(it->ratio_before / it->k_i);
  }
  *standard_error = std::numeric_limits<double>::infinity();
  if (options_.mean_of_drives < 2 || static_cast<int>(ratios.size()) < options_.mean_of_drives)
    return false;
  const auto meanOf = [&](int n, double* m, double* error) {
    double sum = 0, squares = 0;
    for (int i = 0; i < n; ++i) sum += ratios[i];
    *m = sum / n;
    for (int i = 0; i < n; ++i) squares += (ratios[i] - *m) * (ratios[i] - *m);
    *error = std::sqrt(squares / (n - 1) / n);
    return *error <= options_.max_mean_error;
  };
  if (meanOf(static_cast<int>(ratios.size()), mean, standard_error)) return true;
  // Those drives disagree: the ratio they measure may have moved during the iteration (the tags
  // under the later drives laid otherwise, the motors warming), and their mean is none of its
  // values. The latest drives' mean, over as few of them as are sure enough (the least lag behind
  // the ratio the robot has now). On none, the whole window's stays for the reason.
  for (int n = options_.mean_of_drives; n < static_cast<int>(ratios.size()); ++n) {
    double m = 0, error = 0;
    if (meanOf(n, &m, &error)) {
      *mean = m;
      *standard_error = error;
      return true;
    }
  }
  return false;
}

void TrimEstimator::rebase(double ratio) {
  if (!(ratio > 0) || !std::isfinite(ratio))
    throw InputError("a wheel speed ratio must be a positive number, got " + formatNumber(ratio));
  const double scale = ratio / ratio_;
  for (TrimIteration& it : history_) {
    it.ratio_before *= scale;
    it.ratio_after *= scale;
    it.step *= scale;
  }
  ratio_ = ratio;
}

}  // namespace wheels
}  // namespace autocal
