// rosrun autocal uah --bag FILE --veh NAME [--straight-length-m 3.0 ...] [--out PATH]
// The UAH odometry calibration (paper 002 §2) recomputed from a bag of a run of
// odometry_calibration_node, no robot and no master: the passive mode (odometry::replayUah). Prints
// the result as YAML and optionally writes the odometry calibration file. doc/nodes/uah.md.

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/format.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal/odometry/uah_replay.h"
#include "autocal/physical_range.h"
#include "autocal_ros/recording.h"

namespace {

using namespace autocal;
using namespace autocal::odometry;

const char* kUsage =
    "usage: uah --bag FILE --veh NAME [--straight-length-m L_m ...] [--out PATH]\n"
    "           [--wheel-radius-m 0.0318] [--wheelbase-m 0.1] [--ticks-per-revolution N]\n"
    "           [--rounds 3] [--max-heading-deviation-rad 0.0349]\n"
    "  Recomputes the UAH result from a bag of odometry_calibration_node's run: the topics\n"
    "  /NAME/left_wheel_encoder_node/tick, /NAME/right_wheel_encoder_node/tick,\n"
    "  /NAME/front_center_tof_driver_node/range, /NAME/wheels_driver_node/wheels_cmd and\n"
    "  /NAME/calibration/status. Commands nothing.\n"
    "  --straight-length-m: the straight runs' true lengths (metres): once for every run, or once\n"
    "  per run in order (repeat it, or a comma-separated list). Default: the lengths recorded on\n"
    "  /NAME/odometry_calibration_node/straight_length.\n"
    "  --wheel-radius-m, --wheelbase-m: the nominal robot the live run was given (its defaults);\n"
    "  --ticks-per-revolution: default from the encoder messages.\n"
    "  --out writes the odometry calibration file (odometry/NAME.yaml) atomically.\n";

struct Args {
  std::string bag, veh, out;
  std::vector<double> lengths_m;
  double wheel_radius_m = 0.0318, wheelbase_m = 0.1, max_heading_deviation_rad = NAN;
  int ticks_per_revolution = 0, rounds = 0;
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
    // roslaunch appends __name:=… and __log:=… when it starts the command as a node.
    if (flag.rfind("__", 0) == 0 && flag.find(":=") != std::string::npos) continue;
    if (i + 1 >= argc) throw UsageError(flag + ": missing value (or unknown option)");
    const std::string value = argv[++i];
    if (flag == "--bag") {
      a.bag = value;
    } else if (flag == "--veh") {
      a.veh = value;
    } else if (flag == "--out") {
      a.out = value;
    } else if (flag == "--straight-length-m") {
      std::stringstream list(value);
      std::string item;
      while (std::getline(list, item, ',')) {
        const double l = parseNumberArg(flag, item);
        if (l <= 0) throw UsageError(flag + ": a length must be > 0 [m], got '" + item + "'");
        a.lengths_m.push_back(l);
      }
    } else if (flag == "--wheel-radius-m") {
      a.wheel_radius_m = parseNumberArg(flag, value);
    } else if (flag == "--wheelbase-m") {
      a.wheelbase_m = parseNumberArg(flag, value);
    } else if (flag == "--ticks-per-revolution") {
      a.ticks_per_revolution = static_cast<int>(parseNumberArg(flag, value));
    } else if (flag == "--rounds") {
      a.rounds = static_cast<int>(parseNumberArg(flag, value));
    } else if (flag == "--max-heading-deviation-rad") {
      a.max_heading_deviation_rad = parseNumberArg(flag, value);
    } else {
      throw UsageError("unknown option " + flag);
    }
  }
  if (a.help) return a;
  if (a.bag.empty()) throw UsageError("--bag FILE is required");
  if (a.veh.empty() || a.veh.find('/') != std::string::npos) {
    throw UsageError("--veh NAME (the robot's namespace, without '/') is required");
  }
  if (!(a.wheel_radius_m > 0) || !(a.wheelbase_m > 0)) {
    throw UsageError("--wheel-radius-m and --wheelbase-m must be > 0");
  }
  // A length in other units than metres is refused before the bag is read.
  std::vector<std::string> slips = {
      outOfRange("--wheel-radius-m", a.wheel_radius_m, ranges::kWheelRadius),
      outOfRange("--wheelbase-m", a.wheelbase_m, ranges::kWheelbase)};
  for (const double l : a.lengths_m)
    slips.push_back(outOfRange("--straight-length-m", l, ranges::kStraightRun));
  for (const std::string& slip : slips)
    if (!slip.empty()) throw ConfigError(slip);
  return a;
}

std::string yamlString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

int run(int argc, char** argv) {
  const Args args = parseArgs(argc, argv);
  if (args.help) {
    std::cout << kUsage;
    return 0;
  }
  ros_layer::Recording recording(args.bag);
  const ros_layer::UahBag bag = ros_layer::readUahRecording(recording, args.veh);
  const int resolution =
      args.ticks_per_revolution > 0 ? args.ticks_per_revolution : bag.ticks_per_revolution;
  UahReplayOptions options;
  options.run.nominal =
      DiffDriveParams::fromWheel(2 * args.wheel_radius_m, resolution, args.wheelbase_m);
  if (args.rounds > 0) options.run.rounds = args.rounds;
  if (std::isfinite(args.max_heading_deviation_rad)) {
    options.run.straight.max_heading_deviation_rad = args.max_heading_deviation_rad;
  }
  options.straight_lengths_m = args.lengths_m;
  const UahReplayResult replay = replayUah(bag.recording, options);
  const UahResult& r = replay.result;
  const OdometryCalibration calibration = r.toOdometryCalibration(args.veh);
  const DiffDriveMultipliers m = calibration.multipliers();

  std::ostringstream y;
  auto kv = [&](const char* key, double v) { y << key << ": " << formatNumber(v) << "\n"; };
  y << "method: uah\n";
  y << "source: passive (bag)\n";
  y << "bag: " << yamlString(args.bag) << "\n";
  y << "vehicle: " << args.veh << "\n";
  y << "recorded_run: " << yamlString(replay.recorded_outcome) << "\n";
  kv("recording_s", replay.recording_s);
  kv("Ed", r.ed.Ed);
  kv("Eb", calibration.Eb);
  kv("wheelbase_m", r.calibrated.wheelbase_m);
  kv("wheelbase_nominal_m", r.nominal.wheelbase_m);
  kv("left_m_per_pulse", r.calibrated.left_m_per_pulse);
  kv("right_m_per_pulse", r.calibrated.right_m_per_pulse);
  kv("left_wheel_radius_multiplier", m.left_wheel_radius_multiplier);
  kv("right_wheel_radius_multiplier", m.right_wheel_radius_multiplier);
  kv("wheel_separation_multiplier", m.wheel_separation_multiplier);
  kv("right_pulses_per_round_left_stopped", r.ed.right_pulses_per_round);
  kv("left_pulses_per_round_right_stopped", r.ed.left_pulses_per_round);
  kv("pivot_radius_m", r.wheelbase.pivot_radius_m);
  y << "turns:\n";
  size_t t = 0;
  for (const UahReplayMotion& motion : replay.motions) {
    if (motion.experiment == UahExperiment::kStraight ||
        motion.experiment == UahExperiment::kFace) {
      continue;  // the turn back to the starting heading measures nothing
    }
    const UahTurn& turn = replay.turns.at(t++);
    y << "  - {experiment: " << name(turn.experiment)
      << ", start_s: " << formatNumber(motion.start_s, 7)
      << ", pulses_per_round: " << formatNumber(turn.detection.pulses_per_round)
      << ", rounds_used: " << turn.detection.rounds_used
      << ", recorded_rounds: " << motion.recorded_round
      << ", peak_correlation: " << formatNumber(turn.detection.peak_correlation, 4) << "}\n";
  }
  y << "straight_runs:\n";
  y << "  lengths: " << replay.lengths_source << "\n";
  y << "  runs:\n";
  size_t s = 0;
  for (const UahReplayMotion& motion : replay.motions) {
    if (motion.experiment != UahExperiment::kStraight) continue;
    const StraightRun& run = replay.straight_runs.at(s);
    const bool accepted =
        std::find(r.straight.accepted_runs.begin(), r.straight.accepted_runs.end(),
                  static_cast<int>(s)) != r.straight.accepted_runs.end();
    ++s;
    y << "    - {start_s: " << formatNumber(motion.start_s, 7)
      << ", length_m: " << formatNumber(run.length_m)
      << ", right_pulses: " << formatNumber(run.right_pulses)
      << ", heading_deviation_deg: " << formatNumber(run.max_heading_deviation_rad * 180 / M_PI, 3)
      << ", shortening_pct: " << formatNumber(100 * run.shortening, 3)
      << ", accepted: " << (accepted ? "true" : "false") << "}\n";
  }
  if (!args.out.empty()) {
    writeOdometryCalibration(args.out, calibration);  // the quality gate first; atomic
    y << "written: " << args.out << "\n";
  }
  std::cout << y.str();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "uah", [&] { return run(argc, argv); }, kUsage);
}
