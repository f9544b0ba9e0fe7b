// The UAH odometry calibration (paper 002, Maldonado-Bascón et al. 2019): whole-round detection
// from a range sensor (§2.1), the wheel diameter ratio from pivoting on each stopped wheel
// (§2.2), the reference wheel's distance per pulse from a straight run (§2.3), and the wheelbase
// from pivot versus spin-in-place pulses (§2.3). Each step is its own function.
#pragma once

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "autocal/odometry/calibration_file.h"
#include "autocal/odometry/dead_reckoning.h"

namespace autocal {
namespace odometry {

// ---------------------------------------------------------------------------------------------
// Step 1 (§2.1): whole-round detection.

/// One range reading taken while the robot turns: the moving wheel's pulse count at the time of
/// the reading (fractional when interpolated between encoder messages) and the range [m].
/// A NaN, infinite or out-of-range value is a dropout.
struct RangeSample {
  double pulses = 0.0;
  double range_m = 0.0;
};

struct RoundDetectionOptions {
  /// Theoretical pulses per round from the nominal parameters (§2.1's N_t): 2π·b/c for a pivot
  /// on a stopped wheel, π·b/c for a spin in place.
  double expected_pulses_per_round = 0.0;
  /// The peak is searched within N_t·(1 ± window_fraction) (§2.1 uses a window around N_t).
  double window_fraction = 0.1;
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();
  /// Gaps between valid readings up to this many pulses are bridged by linear interpolation;
  /// longer ones stay missing and are left out of the correlation.
  double max_gap_pulses = 6.0;
  /// The normalised autocorrelation at the round must reach this (else: weak peak).
  double min_peak_correlation = 0.7;
  /// Refuse when the autocorrelation at a shorter lag (after its zero-lag lobe) reaches this
  /// fraction of the round's peak: the scene repeats within a round (symmetric or periodic).
  double max_secondary_ratio = 0.8;
  /// Refine the period with the peaks at 2, 3, … rounds when the data covers them.
  bool use_multiple_rounds = true;
  /// Throws ConfigError naming the first bad option.
  void validate() const;
};

struct RoundDetection {
  double pulses_per_round = 0.0;     ///< the refined answer
  double single_round_pulses = 0.0;  ///< from the first peak alone (parabolic refinement)
  double peak_correlation = 0.0;
  double secondary_correlation = 0.0;  ///< highest correlation at a shorter lag
  double secondary_lag_pulses = 0.0;
  int rounds_used = 0;  ///< peaks used in the refinement
  double rounds_covered = 0.0;
  double valid_fraction = 0.0;  ///< share of the pulse grid with a range value
};

/// Finds the pulses per whole round from the autocorrelation of the range readings resampled
/// onto the pulse axis. Throws CalibrationError with the reason when the answer would be
/// unreliable: too few readings, a featureless or periodic scene, a weak peak, a peak on the
/// edge of the window.
RoundDetection detectWholeRound(const std::vector<RangeSample>& samples,
                                const RoundDetectionOptions& options);

/// The normalised autocorrelation of a signal with missing values (NaN), for lags 0..max_lag:
/// Σ a_i·a_{i+k} / sqrt(Σ a_i² · Σ a_{i+k}²) over the pairs where both exist, a = x − mean.
std::vector<double> normalizedAutocorrelation(const std::vector<double>& signal, int max_lag);

/// Resamples readings onto a grid of one pulse starting at the smallest pulse count: readings
/// in the same cell are averaged, short gaps interpolated, long ones NaN.
std::vector<double> resampleOnPulses(const std::vector<RangeSample>& samples,
                                     const RoundDetectionOptions& options, double* first_pulse);

// ---------------------------------------------------------------------------------------------
// Step 2 (§2.2): Ed from pivoting on each stopped wheel.

struct EdEstimate {
  double Ed = 1.0;                      ///< D_R/D_L = N_L/N_R
  double right_pulses_per_round = 0.0;  ///< mean N_R, left wheel stopped
  double left_pulses_per_round = 0.0;   ///< mean N_L, right wheel stopped
  double right_relative_spread = 0.0;   ///< (max − min)/mean over the experiments
  double left_relative_spread = 0.0;
};

/// §2.2: pivoting on one stopped wheel, the other wheel runs once around a circle whose radius
/// b' (the pivot-to-wheel distance) is the same whichever wheel is stopped, so per round
/// 2π·b' = N_R·c_R = N_L·c_L, and Ed = D_R/D_L = c_R/c_L = N_L/N_R. Each vector holds one
/// pulses-per-round value per experiment. Throws InputError on empty or non-positive input and
/// CalibrationError when experiments disagree by more than `max_relative_spread`.
EdEstimate estimateEd(const std::vector<double>& right_pulses_left_stopped,
                      const std::vector<double>& left_pulses_right_stopped,
                      double max_relative_spread = 0.01);

// ---------------------------------------------------------------------------------------------
// Step 3 (§2.3): distance per pulse of the reference (right) wheel from straight runs.

struct StraightRun {
  double length_m = 0.0;                   ///< measured distance from start to end point
  double right_pulses = 0.0;               ///< pulses of the reference wheel over the run
  double max_heading_deviation_rad = 0.0;  ///< largest |heading − initial heading| on the way
  /// 1 − (start-to-end distance) / (path length) by the encoders' dead reckoning: what the
  /// heading's excursions cost the start-to-end distance against the wheel's path [1].
  double shortening = 0.0;
  /// The duties commanded over the run's second half (by the reference wheel's pulses), mean
  /// magnitudes, and the run's direction: the heading held by the encoders with Ed, so a forward
  /// run's duties are those that drive the robot straight, whatever the floor tags say (0: not
  /// recorded). At two speeds, the duties held over the slow window (StraightRunWindows).
  double mean_left_duty = 0.0;
  double mean_right_duty = 0.0;
  /// A forward run at two speeds (StraightRunWindows): the same over its fast part, and
  /// mean_left/right_duty over its slow part (0: one speed).
  double fast_left_duty = 0.0;
  double fast_right_duty = 0.0;
  /// How far the left wheel fell behind the right one over each window, as a share of the right
  /// wheel's pulses there (PulseLine::leftLag by the run's own Ed): 0.17 % of the wheels' speed
  /// ratio is 3 cm of drift in 2 m. At two speeds straightRunFit takes the held duties level by
  /// it; at one speed (the heading hold throughout) it is recorded only: there the mean duty errs
  /// by the loop's dithering more than by the lag (0: not recorded).
  double slow_left_lag = 0.0;
  double fast_left_lag = 0.0;
  bool forward = true;
};

/// Where a straight run's duties are taken, as shares of its right wheel's pulses: past the
/// start's ramp and transient and, at two speeds, past the change of speed. At two speeds each
/// speed's duties are the mean the heading hold commanded over a settling stretch, then held
/// fixed over the window while the wheels' pulses give the speed ratio those duties make: a
/// closed loop's mean duty is as far from the level one as its dithering over the window's ends
/// (a few 0.1 % of the ratio on the drawn robots, through 30-100 ms of command and reading
/// latency), while fixed duties and the slope of one wheel's pulses on the other's leave under
/// 0.05 %.
struct StraightRunWindows {
  double begin = 0.5;  ///< one speed: the second half, from here to the run's end
  /// Two speeds: the slow part (in the first half) and the fast one (from here to the end), each
  /// after its settling stretch.
  double slow_settle = 0.1, slow_begin = 0.2, slow_end = 0.5;
  double fast_settle = 0.62, fast_begin = 0.72;
  /// The pulses' slope is taken from this long after the duties were fixed [s]: the wheels reach
  /// their speeds for them one command and reading latency and a motor's lag later (about 0.1 s
  /// on a robot, more on a loaded computer).
  double hold_settle_s = 0.5;
};

/// A window's left pulse counts against its right ones, for the left wheel's lag
/// (StraightRun::slow_left_lag): the least-squares slope of the counts takes out their ticks'
/// quantisation, which the window's two ends alone leave at about a pulse (0.17 % of 600).
struct PulseLine {
  double n = 0, r = 0, l = 0, rr = 0, rl = 0;
  void add(double left_pulses, double right_pulses);
  /// 1 − slope/Ed: how far the left wheel fell behind as a share of the right one's pulses; 0
  /// with fewer than three readings or no right pulses.
  double leftLag(double Ed) const;
};

struct StraightRunOptions {
  /// §2.3: a run whose heading strays by θ shortens the start-to-end distance by at most
  /// 1 − cos θ against the wheel's path: 0.015 % at 1°, 0.06 % at 2°. The paper bounds the
  /// heading; what the distance per pulse needs bounded is that shortening, which a brief
  /// excursion (a wheel that starts late: static friction, gearbox play) hardly adds to. A run is
  /// rejected when its shortening is over max_shortening (1 − cos 2°, the paper's bound as a
  /// distance), or when its heading strayed over max_heading_deviation_rad at all (it did not go
  /// straight). In robot mode a robot whose wheels break away at 0.12 for a deadband of 0.09
  /// strayed 2.4-3.4° in every run, and the paper's 2° bound rejected all four.
  double max_heading_deviation_rad = 5.0 * M_PI / 180.0;
  double max_shortening = 1.0 - 0.99939082701909576;  // 1 − cos 2°
  /// A run can lose distance against its pulses (a wheel that slips or rubs a wall, a path that
  /// curves) but not gain it: a run whose distance per pulse is more than this fraction below the
  /// largest of the runs kept for their heading is rejected too. Honest runs agree within about
  /// 0.15 % (a 1 mm tape, a pulse in 2000, 0.06 % at 2°); a run along a wall came out 0.6-2.3 %
  /// short in the simulator [1].
  double max_disagreement = 0.005;
  void validate() const;
};

struct MmPerPulseEstimate {
  double right_m_per_pulse = 0.0;
  std::vector<int> accepted_runs;
  std::vector<int> rejected_runs;
  std::vector<std::string> rejection_reasons;
};

/// §2.3: c_R = (actual distance)/N_R, averaged over the accepted runs: those within the heading
/// bound, less any that lost distance against the others (max_disagreement). Throws
/// CalibrationError when every run is rejected, InputError for a non-positive length or pulse
/// count.
MmPerPulseEstimate estimateMmPerPulse(const std::vector<StraightRun>& runs,
                                      const StraightRunOptions& options = StraightRunOptions());

/// The largest |heading − initial heading| [rad] over cumulative (left, right) pulse counts,
/// from dead reckoning with `params` (the heading only needs the wheel ratio and b roughly).
double maxHeadingDeviationRad(const std::vector<std::pair<double, double>>& cumulative_pulses,
                              const DiffDriveParams& params);
/// StraightRun::shortening over the same readings: 1 − |end − start| / path length (0 when the
/// path is empty).
double pathShortening(const std::vector<std::pair<double, double>>& cumulative_pulses,
                      const DiffDriveParams& params);

// ---------------------------------------------------------------------------------------------
// Step 4 (§2.3): wheelbase from pivot versus spin-in-place pulses.

struct WheelbaseEstimate {
  double wheelbase_m = 0.0;          ///< effective b, from the spin in place
  double pivot_radius_m = 0.0;       ///< b', from the pivot on the stopped left wheel
  double pivot_to_spin_ratio = 0.0;  ///< N_pivot,R / N_spin: 2 when b' = b and c_L = c_R
};

/// A spin in place (both wheels at the same pulse rate, opposite) turns the robot by
/// (N_s·c_R + N_s·c_L)/b per N_s pulses of each wheel, so one round gives
/// b = N_s·(c_L + c_R)/(2π); a pivot on the stopped left wheel gives b' = N_p,R·c_R/(2π), and
/// b = b'·N_s·(c_L + c_R)/(N_p,R·c_R) relates the two (the pivot piece of §2.2 makes b' ≠ b).
WheelbaseEstimate estimateWheelbase(double spin_pulses_per_round,
                                    double pivot_right_pulses_per_round, double left_m_per_pulse,
                                    double right_m_per_pulse);

// ---------------------------------------------------------------------------------------------
// The whole method.

struct UahResult {
  EdEstimate ed;
  MmPerPulseEstimate straight;
  WheelbaseEstimate wheelbase;
  DiffDriveParams nominal;
  DiffDriveParams calibrated;  ///< c_L = c_R/Ed, c_R from the straight runs, b from the spin

  /// The odometry file's record (method "uah"), with the multipliers against `nominal`.
  OdometryCalibration toOdometryCalibration(const std::string& vehicle) const;
  /// diff_drive_controller's multipliers against `nominal`.
  DiffDriveMultipliers multipliers() const { return toOdometryCalibration("").multipliers(); }
};

/// Steps 2–4 in the paper's order: Ed, then c_R (reference wheel), c_L = c_R/Ed, then b.
UahResult computeUah(const DiffDriveParams& nominal,
                     const std::vector<double>& right_pulses_left_stopped,
                     const std::vector<double>& left_pulses_right_stopped,
                     const std::vector<StraightRun>& straight_runs, double spin_pulses_per_round,
                     const StraightRunOptions& straight_options = StraightRunOptions());

}  // namespace odometry
}  // namespace autocal
