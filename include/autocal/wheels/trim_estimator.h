// The wheel calibration of paper 000 §3.4, in wheel speeds: the robot drives forward for a fixed
// time with commanded wheel speeds ω_l = ω and ω_r = k·ω, and the floor tags' heading changes by
// Δθ. With the nominal radius R and wheelbase L, Δθ = R(c·k·φ_l − φ_l)/L, where φ_l is the angle
// the left wheel turned (Δt·ω in the paper; the encoders' when known) and c the unknown true
// right/left speed factor, so this drive says the ratio should have been k/k_i with
// k_i = 1 + Δθ·L/(R·φ_l) (the paper's k_i, eq. 4, with the wheel roles named). k moves towards it
// by a damped step — the paper's (k_i − 1)/2 — an update whose size is below E is ignored, and
// three ignored in a row end the calibration.
//
// On a floor where the wheels slip at random, each drive's heading carries noise that may keep
// updates above E; after max_iterations drives the mean of the last drives' ratios is taken once
// its standard error is small enough (TrimEstimatorOptions::mean_of_drives).
//
// Beyond the paper: far from straight (|k_i − 1| ≥ full_step_above), where a drive's noise is small
// against its signal, the step is the whole correction, so a robot 20 % off converges in a few
// drives instead of eight halvings; once converged, k is the mean of what the ignored drives
// measured (each below E, together they still carry a consistent residual); a drive whose k_i is
// implausible (a mis-detection, a tag read at another orientation) is rejected and repeated, never
// averaged in.
#pragma once

#include <string>
#include <vector>

namespace autocal {
namespace wheels {

struct TrimEstimatorOptions {
  /// k at the start: commanded right/left wheel-speed ratio (1 = the wheels are assumed equal).
  double initial_ratio = 1.0;
  /// E: an update of k smaller than this is ignored [1].
  double min_update = 0.0003;
  /// This many ignored updates in a row: converged (paper: three).
  int ignored_to_converge = 3;
  /// The damping of the paper's update ((k_i − 1)/2: 0.5).
  double damping = 0.5;
  /// |k_i − 1| at or above this: the full correction, not the damped one (0 = always full,
  /// > max_measured_deviation = always damped as in the paper).
  double full_step_above = 0.01;
  /// A drive with |k_i − 1| above this is rejected as a mis-measurement [1].
  double max_measured_deviation = 0.35;
  /// Drives rejected in a row before the calibration fails.
  int max_rejected_in_a_row = 3;
  /// Drives in all (counted or not) before the calibration fails unconverged.
  int max_iterations = 14;
  /// Beyond the paper, for a robot whose wheels slip at random: once max_iterations drives pass
  /// without three small updates in a row, the last plausible drives' ratios (k / k_i each) are
  /// averaged after each drive, `mean_of_drives` of them and one more for each drive beyond
  /// max_iterations, and the mean is the result as soon as its standard error is at most
  /// `max_mean_error` [1]. When that window's drives disagree, the mean of the latest drives is
  /// taken once it is that sure, over as few as are (mean_of_drives at least): a ratio that moved
  /// during the iteration leaves early drives that no longer agree. After
  /// `more_drives_for_mean` more drives without a sure mean the calibration fails.
  /// mean_of_drives 0: off.
  int mean_of_drives = 12;
  double max_mean_error = 0.0005;
  int more_drives_for_mean = 16;
  /// k leaving [1/(1+d), 1+d] means the estimate diverged: failure.
  double max_ratio_deviation = 0.6;
  /// Nominal wheel radius R and wheelbase L (Duckietown's defaults) [m]: their error scales every
  /// k_i alike, which the iteration absorbs.
  double wheel_radius_m = 0.0318;
  double wheelbase_m = 0.1;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// What one drive did to k.
struct TrimIteration {
  double ratio_before = 1;     ///< k during the drive
  double delta_theta_rad = 0;  ///< measured heading change [rad]
  double left_angle_rad = 0;   ///< left wheel's turn [rad]
  double k_i = 1;              ///< this drive's correction factor
  double step = 0;             ///< change of k applied (0 when ignored or rejected)
  double ratio_after = 1;
  bool ignored = false;   ///< |update| < E
  bool rejected = false;  ///< implausible k_i
};

class TrimEstimator {
 public:
  explicit TrimEstimator(const TrimEstimatorOptions& options);

  /// The commanded right/left wheel-speed ratio to drive with now.
  double ratio() const { return ratio_; }
  /// Adds one forward drive: its heading change [rad, counter-clockwise] and how far the left
  /// wheel turned [rad, > 0]. Throws CalibrationError when the calibration fails (diverged, too
  /// many rejected drives, not converged within max_iterations); InputError on a non-finite or
  /// non-positive angle. Must not be called once converged().
  const TrimIteration& addDrive(double delta_theta_rad, double left_angle_rad);
  /// Re-expresses k as `ratio` [> 0]: the drives so far were commanded through deadband offsets
  /// that the motor fit has since moved, and the same duties are now written with another k
  /// (rebaseOnFit in wheel_run.h). The history's k before and after each drive are scaled alike,
  /// so the converged mean stays in one model. Throws InputError on a non-positive ratio.
  void rebase(double ratio);

  bool converged() const { return converged_; }
  int iterations() const { return static_cast<int>(history_.size()); }
  const std::vector<TrimIteration>& history() const { return history_; }
  const TrimEstimatorOptions& options() const { return options_; }

 private:
  /// The mean of the last plausible drives' ratios and its standard error: the growing window's,
  /// or the smallest window of the latest ones (at least mean_of_drives) that is sure enough; true
  /// when one is (its standard error at most max_mean_error). On false, the growing window's.
  bool meanOfLastDrives(double* mean, double* standard_error) const;

  TrimEstimatorOptions options_;
  double ratio_;
  bool converged_ = false;
  int ignored_in_a_row_ = 0;
  int rejected_in_a_row_ = 0;
  std::vector<TrimIteration> history_;
};

}  // namespace wheels
}  // namespace autocal
