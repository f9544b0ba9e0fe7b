// rosrun autocal umbmark --errors FILE.yaml --side 1.0 --wheelbase 0.102
//     [--expressions original|corrected] [--out odometry/<veh>.yaml --veh NAME]
// UMBmark from measured return errors; prints the result as YAML and optionally writes the
// odometry calibration file. Needs no ROS master. doc/nodes/umbmark.md.
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/format.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal/odometry/umbmark.h"
#include "autocal/physical_range.h"

namespace {

using namespace autocal;
using namespace autocal::odometry;

const char* kUsage =
    "usage: umbmark --errors FILE.yaml --side L_m --wheelbase b_m\n"
    "               [--expressions original|corrected] [--out PATH --veh NAME]\n"
    "  FILE.yaml holds cw: [[x, y], ...] and ccw: [[x, y], ...], the return errors\n"
    "  (actual - computed end position, metres) of the clockwise and counter-clockwise runs.\n"
    "  --expressions: Borenstein's original or the corrected ones (default: corrected).\n"
    "  --out writes the odometry calibration file (e.g. odometry/<veh>.yaml) atomically.\n";

struct Args {
  std::string errors_file, expressions = "corrected", out, veh;
  double side_m = NAN, wheelbase_m = NAN;
  bool help = false;
};

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      a.help = true;
      continue;
    }
    if (i + 1 >= argc) throw UsageError(flag + ": missing value (or unknown option)");
    const std::string value = argv[++i];
    if (flag == "--errors")
      a.errors_file = value;
    else if (flag == "--side")
      a.side_m = parseNumberArg(flag, value);
    else if (flag == "--wheelbase")
      a.wheelbase_m = parseNumberArg(flag, value);
    else if (flag == "--expressions")
      a.expressions = value;
    else if (flag == "--out")
      a.out = value;
    else if (flag == "--veh")
      a.veh = value;
    else
      throw UsageError("unknown option " + flag);
  }
  if (a.help) return a;
  if (a.errors_file.empty()) throw UsageError("--errors FILE.yaml is required");
  if (std::isnan(a.side_m)) throw UsageError("--side (the square's side, metres) is required");
  if (std::isnan(a.wheelbase_m)) throw UsageError("--wheelbase (nominal, metres) is required");
  if (!a.out.empty() && a.veh.empty()) throw UsageError("--out needs --veh NAME");
  return a;
}

int run(int argc, char** argv) {
  const Args args = parseArgs(argc, argv);
  if (args.help) {
    std::cout << kUsage;
    return 0;
  }
  UmbmarkOptions options;
  options.side_m = args.side_m;
  options.wheelbase_m = args.wheelbase_m;
  options.expressions = umbmarkExpressionsFromName(args.expressions);
  options.validate();
  // A length in other units than metres is refused before any file is read or written.
  for (const std::string& slip : {outOfRange("--side", args.side_m, ranges::kUmbmarkSide),
                                  outOfRange("--wheelbase", args.wheelbase_m, ranges::kWheelbase)})
    if (!slip.empty()) throw ConfigError(slip);

  std::vector<ReturnError> cw, ccw;
  loadUmbmarkErrors(args.errors_file, &cw, &ccw);
  const UmbmarkResult r = computeUmbmark(cw, ccw, options);
  const OdometryCalibration calibration =
      toOdometryCalibration(r, options, args.veh, args.errors_file);
  const DiffDriveMultipliers m = calibration.multipliers();

  std::ostringstream y;
  auto kv = [&](const char* key, double v) { y << key << ": " << formatNumber(v) << "\n"; };
  y << "method: umbmark\n";
  y << "expressions: " << toString(r.expressions) << "\n";
  kv("side_m", options.side_m);
  kv("wheelbase_nominal_m", options.wheelbase_m);
  y << "runs_cw: " << r.runs_cw << "\nruns_ccw: " << r.runs_ccw << "\n";
  kv("x_cg_cw_m", r.x_cg_cw_m);
  kv("y_cg_cw_m", r.y_cg_cw_m);
  kv("x_cg_ccw_m", r.x_cg_ccw_m);
  kv("y_cg_ccw_m", r.y_cg_ccw_m);
  kv("E_max_syst_m", r.E_max_syst_m);
  kv("alpha_rad", r.alpha_rad);
  kv("alpha_deg", r.alpha_rad * 180.0 / M_PI);
  kv("beta_rad", r.beta_rad);
  kv("beta_deg", r.beta_rad * 180.0 / M_PI);
  kv("R_m", r.R_m);
  kv("Ed", r.Ed);
  kv("Eb", r.Eb);
  kv("wheelbase_actual_m", r.wheelbase_actual_m);
  kv("c_L", r.left_pulse_factor);
  kv("c_R", r.right_pulse_factor);
  kv("left_wheel_radius_multiplier", m.left_wheel_radius_multiplier);
  kv("right_wheel_radius_multiplier", m.right_wheel_radius_multiplier);
  kv("wheel_separation_multiplier", m.wheel_separation_multiplier);
  if (!args.out.empty()) {
    writeOdometryCalibration(args.out, calibration);
    y << "written: " << args.out << "\n";
  }
  std::cout << y.str();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "umbmark", [&] { return run(argc, argv); }, kUsage);
}
