// UMBmark (Borenstein & Feng 1996): systematic odometry errors from the return errors of n
// clockwise and n counter-clockwise runs around an L×L square, in Borenstein's original
// expressions and in corrected ones (paper 002 §1.2 and §3.2, its refs. [18] and [22]).
//
// Conventions (the ones under which Borenstein's expressions hold): the robot starts at the
// origin heading along +x; the first leg goes along +x; a clockwise run turns right at each
// corner (the square lies at y < 0), a counter-clockwise run turns left. A return error is
// ε = actual − computed position [m] (paper 002 §3.2).
#pragma once

#include <string>
#include <vector>

#include "autocal/odometry/calibration_file.h"
#include "autocal/odometry/dead_reckoning.h"

namespace autocal {
namespace odometry {

struct ReturnError {
  double x_m = 0.0;
  double y_m = 0.0;
};

enum class UmbmarkExpressions {
  kOriginal,   ///< Borenstein & Feng's closed forms (first order in α, β; chord form of R)
  kCorrected,  ///< the exact square model inverted (see umbmark.cpp)
};
/// "original" or "corrected"; throws ConfigError otherwise.
UmbmarkExpressions umbmarkExpressionsFromName(const std::string& name);
std::string toString(UmbmarkExpressions expressions);

struct UmbmarkOptions {
  double side_m = 0.0;       ///< L, the side of the square
  double wheelbase_m = 0.0;  ///< nominal wheelbase b used while driving the square
  UmbmarkExpressions expressions = UmbmarkExpressions::kCorrected;
  /// |β| below this leaves R unbounded: Ed is then 1 within precision and is refused.
  double min_abs_beta_rad = 1e-9;
  /// Throws ConfigError naming the first bad option.
  void validate() const;
};

struct UmbmarkResult {
  UmbmarkExpressions expressions = UmbmarkExpressions::kCorrected;
  int runs_cw = 0;
  int runs_ccw = 0;
  double x_cg_cw_m = 0.0, y_cg_cw_m = 0.0;    ///< centre of gravity of the cw errors
  double x_cg_ccw_m = 0.0, y_cg_ccw_m = 0.0;  ///< centre of gravity of the ccw errors
  double r_cg_cw_m = 0.0, r_cg_ccw_m = 0.0;
  double E_max_syst_m = 0.0;  ///< max(r_cg_cw, r_cg_ccw): the UMBmark measure of odometry error
  double alpha_rad = 0.0;     ///< turn error at each corner (the robot turns π/2 − α)
  double beta_rad = 0.0;      ///< heading change over each straight leg (positive: to the left)
  double R_m = 0.0;           ///< radius of the curved legs (signed like β)
  double Ed = 1.0;            ///< D_R/D_L
  double Eb = 1.0;            ///< b_actual/b_nominal
  double wheelbase_actual_m = 0.0;
  double left_pulse_factor = 1.0;   ///< correction factor of the left wheel's distance per pulse
  double right_pulse_factor = 1.0;  ///< correction factor of the right wheel's distance per pulse

  /// diff_drive_controller's multipliers: c_L, c_R and Eb.
  DiffDriveMultipliers multipliers() const { return {left_pulse_factor, right_pulse_factor, Eb}; }
};

/// Computes UMBmark from the return errors. Throws InputError for an empty or one-sided list or
/// a non-finite entry, ConfigError for bad options, and CalibrationError when the errors do not
/// determine a correction (β so small that R is unbounded, or errors too large to be a square).
UmbmarkResult computeUmbmark(const std::vector<ReturnError>& cw,
                             const std::vector<ReturnError>& ccw, const UmbmarkOptions& options);

/// E_max,syst alone (centres of gravity of both directions), for comparing before and after.
double umbmarkEmaxSyst(const std::vector<ReturnError>& cw, const std::vector<ReturnError>& ccw);

/// The result as the odometry file's record (method "umbmark"), with its inputs.
OdometryCalibration toOdometryCalibration(const UmbmarkResult& result,
                                          const UmbmarkOptions& options, const std::string& vehicle,
                                          const std::string& errors_file);

/// Reads `cw: [[x, y], ...]` and `ccw: [[x, y], ...]` [m] from a YAML file; InputError or
/// ConfigError with the file and line on anything else.
void loadUmbmarkErrors(const std::string& path, std::vector<ReturnError>* cw,
                       std::vector<ReturnError>* ccw);

}  // namespace odometry
}  // namespace autocal
