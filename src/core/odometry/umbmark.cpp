#include "autocal/odometry/umbmark.h"

#include <Eigen/Dense>
#include <cmath>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"
#include "square_model.h"

namespace autocal {
namespace odometry {

namespace {

void checkErrors(const std::vector<ReturnError>& errors, const char* name) {
  if (errors.empty()) {
    throw InputError(std::string("UMBmark needs return errors of both directions; the ") + name +
                     " list is empty");
  }
  for (size_t i = 0; i < errors.size(); ++i) {
    if (!std::isfinite(errors[i].x_m) || !std::isfinite(errors[i].y_m)) {
      throw InputError(std::string(name) + "[" + std::to_string(i) + "] is not a finite number");
    }
  }
}

ReturnError centreOfGravity(const std::vector<ReturnError>& errors) {
  ReturnError cg;
  for (const auto& e : errors) {
    cg.x_m += e.x_m;
    cg.y_m += e.y_m;
  }
  cg.x_m /= static_cast<double>(errors.size());
  cg.y_m /= static_cast<double>(errors.size());
  return cg;
}

// The exact square model: the return errors (x_cw, y_cw, x_ccw, y_ccw) of a robot whose true
// parameters are the nominal ones corrected by (Ed, Eb), driven by nominal odometry. The
// distance per pulse cancels out of the geometry, so any nominal value serves.
Eigen::Vector4d squareModel(double Ed, double Eb, double side_m, double wheelbase_m) {
  DiffDriveParams nominal;
  nominal.left_m_per_pulse = nominal.right_m_per_pulse = 1e-3;
  nominal.wheelbase_m = wheelbase_m;
  const DiffDriveParams truth = applyUmbmarkCorrection(nominal, Ed, Eb);
  const ReturnError cw = simulateUmbmarkSquare(truth, nominal, side_m, true);
  const ReturnError ccw = simulateUmbmarkSquare(truth, nominal, side_m, false);
  return Eigen::Vector4d(cw.x_m, cw.y_m, ccw.x_m, ccw.y_m);
}

}  // namespace

UmbmarkExpressions umbmarkExpressionsFromName(const std::string& name) {
  if (name == "original") return UmbmarkExpressions::kOriginal;
  if (name == "corrected") return UmbmarkExpressions::kCorrected;
  throw ConfigError("expressions: expected original or corrected, got '" + name + "'");
}

std::string toString(UmbmarkExpressions expressions) {
  return expressions == UmbmarkExpressions::kOriginal ? "original" : "corrected";
}

void UmbmarkOptions::validate() const {
  if (!std::isfinite(side_m) || side_m <= 0.0) {
    throw ConfigError("side_m: the side of the square must be positive, got " +
                      formatNumber(side_m));
  }
  if (!std::isfinite(wheelbase_m) || wheelbase_m <= 0.0) {
    throw ConfigError("wheelbase_m: the nominal wheelbase must be positive, got " +
                      formatNumber(wheelbase_m));
  }
  if (!(min_abs_beta_rad > 0.0)) throw ConfigError("min_abs_beta_rad must be positive");
}

double umbmarkEmaxSyst(const std::vector<ReturnError>& cw, const std::vector<ReturnError>& ccw) {
  checkErrors(cw, "cw");
  checkErrors(ccw, "ccw");
  const ReturnError a = centreOfGravity(cw), b = centreOfGravity(ccw);
  return std::max(std::hypot(a.x_m, a.y_m), std::hypot(b.x_m, b.y_m));
}

UmbmarkResult computeUmbmark(const std::vector<ReturnError>& cw,
                             const std::vector<ReturnError>& ccw, const UmbmarkOptions& options) {
  options.validate();
  checkErrors(cw, "cw");
  checkErrors(ccw, "ccw");
  const double L = options.side_m;
  const double b = options.wheelbase_m;

  UmbmarkResult r;
  r.expressions = options.expressions;
  r.runs_cw = static_cast<int>(cw.size());
  r.runs_ccw = static_cast<int>(ccw.size());
  const ReturnError gcw = centreOfGravity(cw), gccw = centreOfGravity(ccw);
  r.x_cg_cw_m = gcw.x_m;
  r.y_cg_cw_m = gcw.y_m;
  r.x_cg_ccw_m = gccw.x_m;
  r.y_cg_ccw_m = gccw.y_m;
  r.r_cg_cw_m = std::hypot(gcw.x_m, gcw.y_m);
  r.r_cg_ccw_m = std::hypot(gccw.x_m, gccw.y_m);
  r.E_max_syst_m = std::max(r.r_cg_cw_m, r.r_cg_ccw_m);

  // [18] (Borenstein & Feng), to first order in α and β. Leg k of the square starts with the
  // heading error δ_k = k(β − sα) (s = +1 ccw, −1 cw: each corner turns s(π/2 − α), each leg
  // bends by β), and its end is displaced sideways by L(δ_k + β/2). Summing the four legs:
  //   x_cw = −2L(α + β), x_ccw = −2L(α − β)  (and y_cw = x_cw, y_ccw = −x_ccw),
  // hence α = (x_cw + x_ccw)/(−4L) and β = (x_cw − x_ccw)/(−4L).
  const double alpha0 = (gcw.x_m + gccw.x_m) / (-4.0 * L);
  const double beta0 = (gcw.x_m - gccw.x_m) / (-4.0 * L);
  if (!(std::abs(beta0) >= options.min_abs_beta_rad)) {
    throw CalibrationError(
        "beta = " + formatNumber(beta0) + " rad is below " +
        formatNumber(options.min_abs_beta_rad) +
        " rad (x_cg_cw and x_cg_ccw are equal within precision): the radius R of the legs is "
        "unbounded, so Ed = 1 within the precision of these errors and there is no wheel "
        "diameter ratio to correct; nothing was computed");
  }
  if (!(std::abs(alpha0) < 0.5 * M_PI) || !(std::abs(beta0) < 0.5 * M_PI)) {
    throw CalibrationError("the return errors are too large for a square of side " +
                           formatNumber(L) + " m (alpha = " + formatNumber(alpha0) +
                           " rad, beta = " + formatNumber(beta0) +
                           " rad): check the units (metres) and the side");
  }

  if (options.expressions == UmbmarkExpressions::kOriginal) {
    r.alpha_rad = alpha0;
    r.beta_rad = beta0;
    // [18]: the curved leg is taken as an arc whose CHORD is L: R = (L/2)/sin(β/2); the
    // wheels run at R ± b/2 with the NOMINAL b, so Ed = D_R/D_L = (R + b/2)/(R − b/2).
    r.R_m = (L / 2.0) / std::sin(beta0 / 2.0);
    if (!(std::abs(r.R_m) > b / 2.0)) {
      throw CalibrationError("R = " + formatNumber(r.R_m) +
                             " m is not larger than b/2: the return "
                             "errors are too large for this square and wheelbase");
    }
    r.Ed = (r.R_m + b / 2.0) / (r.R_m - b / 2.0);
    // [18]: the robot turned 90° − α where odometry counted 90°, so Eb = 90°/(90° − α).
    r.Eb = (M_PI / 2.0) / (M_PI / 2.0 - alpha0);
  } else {
    // Corrected expressions. Paper 002 §1.2 says its ref. [22] corrects [18]'s expressions and
    // iterates them; the equations themselves did not survive in our copy of the paper, so
    // this is our own derivation of what [18] approximates, not a transcription of [22]:
    //  (1) no small-angle expansion: the square is modelled exactly — legs are arcs of LENGTH
    //      L (odometry counted L of centre travel; the chord is shorter), corners are spins on
    //      the spot that also shift the centre by (ΔS_R + ΔS_L)/2 when D_R ≠ D_L;
    //  (2) all four centre-of-gravity coordinates are used, not only the two x's;
    //  (3) the legs' radius uses the ACTUAL wheelbase Eb·b, not the nominal one.
    // (Ed, Eb) are found by Gauss-Newton on the exact model, started at [18]'s answer.
    const Eigen::Vector4d measured(gcw.x_m, gcw.y_m, gccw.x_m, gccw.y_m);
    double Ed = 1.0, Eb = (M_PI / 2.0) / (M_PI / 2.0 - alpha0);
    {
      const double R0 = (L / 2.0) / std::sin(beta0 / 2.0);
      if (std::abs(R0) > b / 2.0) Ed = (R0 + b / 2.0) / (R0 - b / 2.0);
    }
    Eigen::Vector2d p(Ed, Eb);
    for (int iter = 0; iter < 30; ++iter) {
      const Eigen::Vector4d f = squareModel(p[0], p[1], L, b);
      Eigen::Matrix<double, 4, 2> J;
      const double h = 1e-7;
      J.col(0) = (squareModel(p[0] + h, p[1], L, b) - squareModel(p[0] - h, p[1], L, b)) / (2 * h);
      J.col(1) = (squareModel(p[0], p[1] + h, L, b) - squareModel(p[0], p[1] - h, L, b)) / (2 * h);
      const Eigen::Vector2d step = J.colPivHouseholderQr().solve(measured - f);
      p += step;
      if (!(p[0] > 0.0) || !(p[1] > 0.0) || !std::isfinite(p[0]) || !std::isfinite(p[1])) {
        throw CalibrationError(
            "the exact square model does not fit these return errors "
            "(Ed or Eb left the positive range): check the data");
      }
      if (step.norm() < 1e-13) break;
    }
    r.Ed = p[0];
    r.Eb = p[1];
    r.alpha_rad = (M_PI / 2.0) * (1.0 - 1.0 / r.Eb);
    // Each leg: N = L/c pulses per wheel; the wheels travel N·c_R and N·c_L, so the heading
    // changes by β = L(c_R − c_L)/(c·b_actual) = 2L(Ed − 1)/((Ed + 1)·Eb·b) over an arc of
    // length L: R = L/β, and then Ed = (R + b_actual/2)/(R − b_actual/2) holds exactly.
    r.beta_rad = 2.0 * L * (r.Ed - 1.0) / ((r.Ed + 1.0) * r.Eb * b);
    if (!(std::abs(r.beta_rad) >= options.min_abs_beta_rad)) {
      throw CalibrationError("beta = " + formatNumber(r.beta_rad) +
                             " rad: R is unbounded, Ed = 1 within the precision of the data");
    }
    r.R_m = L / r.beta_rad;
  }
  if (!std::isfinite(r.Ed) || r.Ed <= 0.0 || !std::isfinite(r.Eb) || r.Eb <= 0.0) {
    throw CalibrationError("UMBmark gave Ed = " + formatNumber(r.Ed) +
                           ", Eb = " + formatNumber(r.Eb) + ": not a usable correction");
  }
  r.wheelbase_actual_m = r.Eb * b;
  r.left_pulse_factor = 2.0 / (r.Ed + 1.0);
  r.right_pulse_factor = 2.0 / (1.0 / r.Ed + 1.0);
  return r;
}

OdometryCalibration toOdometryCalibration(const UmbmarkResult& result,
                                          const UmbmarkOptions& options, const std::string& vehicle,
                                          const std::string& errors_file) {
  OdometryCalibration c;
  c.method = "umbmark";
  c.expressions = toString(result.expressions);
  c.vehicle = vehicle;
  c.Ed = result.Ed;
  c.Eb = result.Eb;
  c.wheelbase_nominal_m = options.wheelbase_m;
  c.wheelbase_m = result.wheelbase_actual_m;
  c.left_pulse_factor = result.left_pulse_factor;
  c.right_pulse_factor = result.right_pulse_factor;
  c.inputs = {{"errors_file", "'" + errors_file + "'"},
              {"side_m", formatNumber(options.side_m)},
              {"wheelbase_nominal_m", formatNumber(options.wheelbase_m)},
              {"runs_cw", std::to_string(result.runs_cw)},
              {"runs_ccw", std::to_string(result.runs_ccw)},
              {"x_cg_cw_m", formatNumber(result.x_cg_cw_m)},
              {"y_cg_cw_m", formatNumber(result.y_cg_cw_m)},
              {"x_cg_ccw_m", formatNumber(result.x_cg_ccw_m)},
              {"y_cg_ccw_m", formatNumber(result.y_cg_ccw_m)}};
  return c;
}

ReturnError simulateUmbmarkSquare(const DiffDriveParams& truth, const DiffDriveParams& odometry,
                                  double side_m, bool clockwise) {
  truth.validate();
  odometry.validate();
  DeadReckoning actual(truth), computed(odometry);
  const double s = clockwise ? -1.0 : 1.0;
  for (int leg = 0; leg < 4; ++leg) {
    // Straight per odometry: both wheels travel L by the odometry's own distance per pulse.
    const double nl = side_m / odometry.left_m_per_pulse;
    const double nr = side_m / odometry.right_m_per_pulse;
    actual.addPulses(nl, nr);
    computed.addPulses(nl, nr);
    // Spin on the spot by π/2 per odometry: each wheel travels b·π/4 in opposite directions.
    const double arc = odometry.wheelbase_m * M_PI / 4.0;
    const double tl = -s * arc / odometry.left_m_per_pulse;
    const double tr = s * arc / odometry.right_m_per_pulse;
    actual.addPulses(tl, tr);
    computed.addPulses(tl, tr);
  }
  return ReturnError{actual.pose().x_m - computed.pose().x_m,
                     actual.pose().y_m - computed.pose().y_m};
}

void loadUmbmarkErrors(const std::string& path, std::vector<ReturnError>* cw,
                       std::vector<ReturnError>* ccw) {
  // The errors are measurements, so a malformed file is bad input (not bad configuration): the
  // one YAML reader's ConfigError, with its file, line and key, becomes an InputError.
  try {
    YamlMap root = YamlMap::loadFile(path);
    auto readList = [&](const char* key, std::vector<ReturnError>* out) {
      if (!root.has(key)) root.fail(key, "missing; UMBmark needs runs in both directions");
      const auto pairs = root.required<std::vector<std::vector<double>>>(key);
      if (pairs.empty()) {
        root.fail(key, "the list is empty; UMBmark needs at least one run in each direction");
      }
      out->clear();
      for (size_t i = 0; i < pairs.size(); ++i) {
        if (pairs[i].size() != 2) {
          root.fail(key, "entry " + std::to_string(i) + ": expected a pair [x, y] in metres");
        }
        out->push_back(ReturnError{pairs[i][0], pairs[i][1]});
      }
    };
    readList("cw", cw);
    readList("ccw", ccw);
    root.finish();
  } catch (const ConfigError& e) {
    throw InputError(e.what());
  }
}

}  // namespace odometry
}  // namespace autocal
