// rosrun autocal replay BAG --veh NAME [--calibration-root DIR] [...]
// A recorded calibration run recomputed with no robot and no master: the bag's messages are read
// in the order they were recorded and given to the same replay Stages the run's nodes are built
// on (replay::RunReplay), as fast as the CPU allows; the camera and wheel files and the run's
// report are written under the replay's calibration root. Exits 0 when the replayed run
// succeeded, 1 when it failed (the report and the last line say why), 64 on a bad argument.
// doc/nodes/replay.md.
#include <ros/package.h>
#include <ros/time.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include "autocal/camera/camera_config.h"
#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/odometry/uah_replay.h"
#include "autocal/odometry/uah_run.h"
#include "autocal/physical_range.h"
#include "autocal/replay/run_replay.h"
#include "autocal/report/summary.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/recording.h"

namespace {

namespace fs = std::filesystem;
using namespace autocal;

const char* kUsage =
    "usage: replay BAG --veh NAME [--calibration-root DIR] [--stages camera,wheels,odometry]\n"
    "              [--board 7x5] [--square-m 0.031] [--camera-config FILE] [--tag-size-m 0.065]\n"
    "              [--intrinsics FILE] [--straight-length-m L,...] [--duration-s S]\n"
    "  Recomputes the camera, wheel and odometry stages of a recorded calibration run\n"
    "  (record.launch, or calibrate_sim record:=true) with no robot and no ROS master, and writes\n"
    "  their files and the run's report under the calibration root (./replay_calibrations).\n"
    "  --veh: the recorded robot's name (the namespace of its topics).\n"
    "  --board, --square-m, --camera-config, --tag-size-m: as the live run was given them.\n"
    "  --stages: the stages replayed (default: those the recording holds; wheels without camera\n"
    "  needs --intrinsics, a camera_info YAML).\n"
    "  --straight-length-m: the odometry stage's straight runs' true lengths (default: the\n"
    "  recorded ones), once for every run or once per run.\n"
    "  --duration-s: read only this many seconds of the recording (0: all of it).\n"
    "  Exits 0 when the replayed run succeeded, 1 when it failed, 64 on a bad argument.\n";

struct Args {
  std::string bag, veh, root, board, camera_config, intrinsics;
  std::vector<std::string> stages;  ///< empty: those the recording holds
  std::vector<double> lengths_m;
  double square_m = 0, tag_size_m = 0, duration_s = 0;
  bool help = false;
};

Args parseArgs(int argc, char** argv) {
  Args a;
  const char* pwd = std::getenv("PWD");
  a.root = (fs::path(pwd ? pwd : ".") / "replay_calibrations").string();
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      a.help = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0) {
      if (!a.bag.empty()) throw UsageError("one bag only: '" + a.bag + "' and '" + flag + "'");
      a.bag = flag;
      continue;
    }
    if (i + 1 >= argc) throw UsageError(flag + ": missing value (or unknown option)");
    const std::string value = argv[++i];
    if (flag == "--veh") {
      a.veh = value;
    } else if (flag == "--calibration-root") {
      a.root = fs::absolute(value).string();
    } else if (flag == "--stages") {
      a.stages = splitCommaList(value);
    } else if (flag == "--board") {
      a.board = value;
    } else if (flag == "--square-m") {
      a.square_m = parseNumberArg(flag, value);
    } else if (flag == "--camera-config") {
      a.camera_config = value;
    } else if (flag == "--tag-size-m") {
      a.tag_size_m = parseNumberArg(flag, value);
    } else if (flag == "--intrinsics") {
      a.intrinsics = value;
    } else if (flag == "--straight-length-m") {
      for (const std::string& item : splitCommaList(value)) {
        const double l = parseNumberArg(flag, item);
        if (l <= 0) throw UsageError(flag + ": a length must be > 0 [m], got '" + item + "'");
        a.lengths_m.push_back(l);
      }
    } else if (flag == "--duration-s") {
      a.duration_s = parseNumberArg(flag, value);
    } else {
      throw UsageError("unknown option " + flag);
    }
  }
  if (a.help) return a;
  if (a.bag.empty()) throw UsageError("the recording (BAG) is required");
  if (a.veh.empty() || a.veh.find('/') != std::string::npos)
    throw UsageError("--veh NAME (the recorded robot's namespace, without '/') is required");
  if (a.duration_s < 0) throw UsageError("--duration-s must be >= 0");
  if (a.square_m < 0 || a.tag_size_m < 0)
    throw UsageError("--square-m and --tag-size-m must be > 0");
  // A length in other units than metres is refused before the bag is read.
  std::vector<std::string> slips = {
      a.square_m > 0 ? outOfRange("--square-m", a.square_m, ranges::kBoardSquare) : "",
      a.tag_size_m > 0 ? outOfRange("--tag-size-m", a.tag_size_m, ranges::kTagSize) : ""};
  for (const double l : a.lengths_m)
    slips.push_back(outOfRange("--straight-length-m", l, ranges::kStraightRun));
  for (const std::string& slip : slips)
    if (!slip.empty()) throw UsageError(slip);
  return a;
}

/// The odometry stage recomputed from the whole recording (the nodes' defaults for the nominal
/// robot; the resolution from the encoder messages), as `uah --bag` does.
StageResult replayOdometry(const Args& a, const StageOutput& output) {
  ros_layer::Recording recording(a.bag);
  const ros_layer::UahBag bag = ros_layer::readUahRecording(recording, a.veh);
  odometry::UahReplayOptions options;
  // The nominal robot of odometry_calibration_node's defaults (~wheel_radius_m, ~wheelbase_m).
  options.run.nominal =
      odometry::DiffDriveParams::fromWheel(2 * 0.0318, bag.ticks_per_revolution, 0.1);
  options.straight_lengths_m = a.lengths_m;
  const odometry::UahReplayResult r = odometry::replayUah(bag.recording, options);
  // As the live stage ends: the straight runs' trim into the replayed wheel stage's file.
  return odometry::finishUahStage(output, r.result, r.turns, r.recording_s, r.straight_runs,
                                  options.run.max_trim_disagreement);
}

/// The replay's options: the nodes' defaults with what the live run was given.
replay::RunReplayOptions replayOptions(const Args& a, const std::vector<std::string>& stages) {
  replay::RunReplayOptions o;
  o.veh = a.veh;
  o.calibration_root = a.root;
  o.stages = stages;
  o.odometry = [a](const StageOutput& output) { return replayOdometry(a, output); };
  o.recording = a.bag;
  o.intrinsics_file = a.intrinsics;
  const std::string config =
      a.camera_config.empty() ? ros::package::getPath("autocal") + "/config/camera_calibration.yaml"
                              : a.camera_config;
  o.camera = camera::loadStageCameraConfig(config, a.board, a.square_m);
  o.camera_info_format = ros_layer::cameraInfoYaml;
  // As wheel_calibration_node: the robot's kinematics before the run (the replay's root), and
  // the camera's extrinsics spins in the recorded stage.
  o.wheel_run.kinematics =
      wheels::readKinematicsFileOrDefaults(wheels::kinematicsPath(a.root, a.veh));
  o.wheel_run.extrinsics_spins = 4;
  if (a.tag_size_m > 0) o.wheel_run.detector.tag_size_m = a.tag_size_m;
  o.log = [](const std::string& line) { std::cout << "replay: " << line << std::endl; };
  return o;
}

int run(int argc, char** argv) {
  const Args args = parseArgs(argc, argv);
  if (args.help) {
    std::cout << kUsage;
    return 0;
  }
  ros::Time::init();
  for (const char* folder : {"camera_intrinsic", "kinematics", "odometry", "report"})
    checkWritableFolder((fs::path(args.root) / folder).string());
  // The stages: those asked, else those whose recorded statuses the recording holds.
  std::vector<std::string> stages = args.stages;
  if (stages.empty()) {
    try {
      ros_layer::Recording recording(args.bag);
      stages = ros_layer::recordedStages(recording, args.veh);
    } catch (const InputError&) {
      // Said below, in the report.
    }
    if (stages.empty()) stages = {"camera", "wheels"};
  }
  replay::RunReplay replay(replayOptions(args, stages));
  const std::string report_dir = (fs::path(args.root) / "report" / args.veh).string();
  const auto started = std::chrono::steady_clock::now();
  try {
    ros_layer::Recording recording(args.bag);
    const std::string ns = "/" + args.veh + "/";
    recording.require({ns + "calibration/status", ns + "wheels_driver_node/wheels_cmd",
                       ns + "left_wheel_encoder_node/tick", ns + "right_wheel_encoder_node/tick"},
                      args.veh);
    replay.setFramesUsed(ros_layer::framesUsed(recording, args.veh));
    int printed = -100;
    const ros_layer::RecordingFeed feed =
        ros_layer::feedRecording(recording, args.veh, replay, args.duration_s, [&](double share) {
          const int percent = static_cast<int>(100 * share);
          if (percent < printed + 5) return;
          printed = percent;
          std::cout << "replay: " << replay.describe() << " (" << percent << " % of the recording)"
                    << std::endl;
        });
    std::cout
        << "replay: read " << feed.messages << " messages (" << feed.frames << " frames, "
        << feed.frames_decoded << " decoded) in "
        << formatNumber(
               std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), 3)
        << " s" << std::endl;
  } catch (const InputError& e) {
    replay.abort(std::string("the recording could not be read: ") + e.what());
  }
  std::string warning;
  const report::ReportFiles files = report::writeRunReport(
      report_dir, args.root, args.veh, replay.record(), report::ReportOptions{}, &warning);
  if (!warning.empty()) std::cout << "replay: " << warning << std::endl;
  const report::RunRecord& record = replay.record();
  for (const report::StageRecord& s : record.stages)
    std::cout << "replay: " << s.stage << ": " << s.stateText()
              << (s.file.empty() ? "" : ", " + s.file) << std::endl;
  if (!record.succeeded()) {
    std::cout << "replay: FAILED: " << record.failure() << " (report " << files.summary_yaml << ")"
              << std::endl;
    return toInt(ExitCode::kCalibrationFailed);
  }
  std::cout << "replay: the run succeeded; report in " << report_dir << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return autocal::runCommand(
      "replay", [&] { return run(argc, argv); }, kUsage);
}
