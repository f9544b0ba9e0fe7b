// replay.test: records a simulated calibration, replays it with `rosrun autocal replay` (no robot,
// no simulator, no master: the bag read as fast as the CPU allows), and compares the replay's files
// with the live run's and with the simulator's truth (the robot config, which no node reads); then
// the failures a user meets: a recording cut during the wheel stage, and a file that is not a bag.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <set>

#include "autocal/io/yaml_reader.h"
#include "autocal/sim/config.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/node_runtime.h"
#include "support/ros_wait.h"
#include "support/test_params.h"
#include "support/wheels_in_sim.h"

namespace {

namespace fs = std::filesystem;
using autocal::YamlMap;
using autocal::test::spinUntil;
using autocal::test::testParam;

struct Files {
  std::vector<double> camera_matrix;  ///< empty when there is no camera file
  bool has_kinematics = false;
  autocal::wheels::KinematicsParams kinematics;
};

Files readFiles(const fs::path& root, const std::string& veh) {
  Files f;
  const fs::path camera = root / "camera_intrinsic" / (veh + ".yaml");
  if (fs::exists(camera))
    f.camera_matrix = YamlMap::loadFile(camera.string())
                          .map("camera_matrix")
                          .required<std::vector<double>>("data");
  const fs::path kin = root / "kinematics" / (veh + ".yaml");
  f.has_kinematics = fs::exists(kin);
  if (f.has_kinematics) f.kinematics = autocal::wheels::readKinematicsFile(kin.string());
  return f;
}

/// `rosrun autocal replay` with the args (the boards as the live run's), with no master: its exit
/// status and output.
int replay(const std::string& args, const fs::path& log) {
  const std::string cmd = "ROS_MASTER_URI=http://127.0.0.1:1 rosrun autocal replay " + args +
                          " --board 7x5 --square-m 0.031 > " + log.string() + " 2>&1";
  std::cout << "$ " << cmd << std::endl;
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(Replay, RecordedRunReplayedMatchesLiveAndTruth) {
  const std::string veh = testParam<std::string>("veh");
  const fs::path root = testParam<std::string>("root");
  const fs::path live_root = root / "live", bag = root / "live.bag";
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  // The live run: its report says success, then the recording is closed (SIGINT, as Ctrl-C) and
  // the simulator stopped (its clock would mix with the recording's).
  const fs::path summary = live_root / "report" / veh / "summary.yaml";
  // An earlier test run's files (the stages write only at their ends; the recorder is writing
  // live.bag.active now, which stays).
  ASSERT_TRUE(autocal::test::removeTree(live_root));
  fs::remove(bag);
  ros::NodeHandle nh;
  ASSERT_TRUE(spinUntil([&] { return fs::exists(summary); }, 400.0)) << summary;
  ASSERT_EQ(YamlMap::loadFile(summary.string()).required<std::string>("result"), "success")
      << "the live run failed:\n"
      << readText(summary);
  autocal::test::spinUntilSimTime(ros::Time::now().toSec() + 0.5, 10);
  const int recorder = autocal::ros_layer::nodePid(testParam<std::string>("recorder"));
  ASSERT_GT(recorder, 0) << "rosbag record is not running";
  ASSERT_EQ(::kill(recorder, SIGINT), 0);
  ASSERT_TRUE(
      spinUntil([&] { return fs::exists(bag) && !fs::exists(bag.string() + ".active"); }, 60))
      << "rosbag record did not close " << bag;
  const int sim = autocal::ros_layer::nodePid(testParam<std::string>("sim"));
  ASSERT_GT(sim, 0);
  ASSERT_EQ(::kill(sim, SIGINT), 0);
  ASSERT_TRUE(spinUntil(
      [&] { return autocal::ros_layer::nodePid(testParam<std::string>("sim")) < 0; }, 30));
  std::cout << "recorded " << bag << " (" << fs::file_size(bag) / (1024 * 1024) << " MiB)"
            << std::endl;
  const Files live = readFiles(live_root, veh);
  ASSERT_EQ(live.camera_matrix.size(), 9u);
  ASSERT_TRUE(live.has_kinematics);

  // The replay: the same stages from the bag, into another root.
  const fs::path replay_root = root / "replay";
  fs::remove_all(replay_root);
  const auto started = std::chrono::steady_clock::now();
  const int code =
      replay(bag.string() + " --veh " + veh + " --calibration-root " + replay_root.string(),
             root / "replay.log");
  std::cout << "replay took "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()
            << " s of wall time" << std::endl;
  EXPECT_EQ(code, 0) << readText(root / "replay.log");
  const std::string log_text = readText(root / "replay.log");
  EXPECT_NE(log_text.find("camera: the recorded stage began: replaying it on the"),
            std::string::npos)
      << log_text;
  EXPECT_NE(log_text.find("wheels: the recorded stage began: replaying it on the"),
            std::string::npos)
      << log_text;
  const Files r = readFiles(replay_root, veh);
  ASSERT_EQ(r.camera_matrix.size(), 9u) << readText(root / "replay.log");
  ASSERT_TRUE(r.has_kinematics) << readText(root / "replay.log");
  const double names[4][2] = {{0, robot.camera.truth.fx},
                              {4, robot.camera.truth.fy},
                              {2, robot.camera.truth.cx},
                              {5, robot.camera.truth.cy}};
  for (const auto& n : names) {
    const int i = static_cast<int>(n[0]);
    std::cout << "K[" << i << "]: replay " << r.camera_matrix[i] << ", live "
              << live.camera_matrix[i] << " ("
              << 100 * (r.camera_matrix[i] / live.camera_matrix[i] - 1) << " %), truth " << n[1]
              << std::endl;
    // The same frames as the live stage (its node recorded which): the same calibration.
    EXPECT_NEAR(r.camera_matrix[i], live.camera_matrix[i], 1e-4 * live.camera_matrix[i]);
    EXPECT_NEAR(r.camera_matrix[i], n[1], 0.005 * n[1]);
  }
  const double k_true = (robot.motor_gain_left * robot.wheel_radius_left) /
                        (robot.motor_gain_right * robot.wheel_radius_right);
  const double trim_true = autocal::wheels::trimFromSpeedRatio(k_true, r.kinematics.gain);
  std::cout << "trim: replay " << r.kinematics.trim << ", live " << live.kinematics.trim
            << ", truth " << trim_true << "; deadband replay " << r.kinematics.deadband_left << "/"
            << r.kinematics.deadband_right << ", live " << live.kinematics.deadband_left << "/"
            << live.kinematics.deadband_right << std::endl;
  // A trim and deadbands that differ together command the same duties: the replay is judged by
  // how straight it drives the true robot, as the live run is.
  EXPECT_NEAR(r.kinematics.trim, live.kinematics.trim, 0.002);
  EXPECT_NEAR(r.kinematics.trim, trim_true, 0.01);
  for (const auto& d : autocal::test::straightDrifts(robot, r.kinematics)) {
    std::cout << "drift over 2 m at " << d.speed_mps << " m/s: replay " << d.drift_m << " m"
              << std::endl;
    EXPECT_LE(d.drift_m, d.bound_m) << " at " << d.speed_mps << " m/s";
  }
  EXPECT_NEAR(r.kinematics.deadband_left, live.kinematics.deadband_left, 0.005);
  EXPECT_NEAR(r.kinematics.deadband_right, live.kinematics.deadband_right, 0.005);
  EXPECT_TRUE(fs::exists(replay_root / "report" / veh / "report.png"));
  // The replay says it is one, shows every update of its iteration, and its progress (the console
  // lines "replay: wheels: ... (N % of the recording)") rises with the recording, never back.
  YamlMap replay_summary =
      YamlMap::loadFile((replay_root / "report" / veh / "summary.yaml").string());
  EXPECT_EQ(replay_summary.required<std::string>("replay_of"), bag.string());
  const std::string replay_text = readText(replay_root / "report" / veh / "summary.yaml");
  const auto count_iterations = [](const std::string& text) {
    int n = 0;
    for (std::size_t at = text.find("- {drive: "); at != std::string::npos;
         at = text.find("- {drive: ", at + 1))
      ++n;
    return n;
  };
  const int live_iterations = count_iterations(readText(summary));
  const int replay_iterations = count_iterations(replay_text);
  std::cout << "wheel iterations: live " << live_iterations << ", replay " << replay_iterations
            << std::endl;
  EXPECT_GE(replay_iterations, 2);
  EXPECT_NEAR(replay_iterations, live_iterations, 1);
  std::vector<int> percents;
  const std::string replay_log = readText(root / "replay.log");
  const std::regex progress_line(R"(replay: wheels: [^\n]*\((\d+) % of the recording\))");
  for (auto it = std::sregex_iterator(replay_log.begin(), replay_log.end(), progress_line);
       it != std::sregex_iterator(); ++it)
    percents.push_back(std::stoi((*it)[1]));
  ASSERT_FALSE(percents.empty()) << replay_log;
  EXPECT_TRUE(std::is_sorted(percents.begin(), percents.end()));
  EXPECT_GE(std::set<int>(percents.begin(), percents.end()).size(), 4u);
  EXPECT_GE(percents.back(), 50);

  // Cut during the wheel stage (rosbag play -u: the recording up to halfway through the live wheel
  // stage, which starts when the camera stage ends, a few tenths of a second into the recording):
  // the camera file, a FAILED wheel stage that says why, no kinematics file. The stages' lengths
  // vary between runs at real_time_factor 0 (a camera stage of 28 s in one, 84 s in another).
  YamlMap live_summary = YamlMap::loadFile(summary.string());
  YamlMap live_stages = live_summary.map("stages");
  const double camera_s = live_stages.map("camera").required<double>("duration_s");
  const double wheels_s = live_stages.map("wheels").required<double>("duration_s");
  const int cut_s = static_cast<int>(std::ceil(camera_s + 0.5 * wheels_s));
  std::cout << "cut after " << cut_s << " s (camera " << camera_s << " s, wheels " << wheels_s
            << " s)" << std::endl;
  const fs::path cut_root = root / "cut";
  fs::remove_all(cut_root);
  EXPECT_EQ(replay(bag.string() + " --veh " + veh + " --duration-s " + std::to_string(cut_s) +
                       " --calibration-root " + cut_root.string(),
                   root / "cut.log"),
            1);
  const Files cut = readFiles(cut_root, veh);
  EXPECT_EQ(cut.camera_matrix.size(), 9u);
  EXPECT_FALSE(cut.has_kinematics);
  YamlMap cut_summary = YamlMap::loadFile((cut_root / "report" / veh / "summary.yaml").string());
  EXPECT_EQ(cut_summary.required<std::string>("result"), "failed");
  EXPECT_NE(cut_summary.required<std::string>("failure").find("ended before its wheel stage did"),
            std::string::npos)
      << cut_summary.required<std::string>("failure");

  // Not a bag: the replay ends at once, failed for that reason (the summary and the command's last
  // line say so), and no stage's file is written.
  const fs::path text = root / "not_a_bag.bag";
  std::ofstream(text) << "this is not a bag\n";
  const fs::path bad_root = root / "bad";
  fs::remove_all(bad_root);
  const int bad_status =
      replay(text.string() + " --veh " + veh + " --calibration-root " + bad_root.string(),
             root / "bad.log");
  EXPECT_NE(bad_status, 0);
  EXPECT_EQ(bad_status, 1);
  const Files bad = readFiles(bad_root, veh);
  EXPECT_TRUE(bad.camera_matrix.empty());
  EXPECT_FALSE(bad.has_kinematics);
  EXPECT_FALSE(fs::exists(bad_root / "camera_intrinsic"));
  EXPECT_FALSE(fs::exists(bad_root / "kinematics"));
  const std::string cause =
      "the recording could not be read: " + text.string() + ": cannot open the bag (not a bag";
  const fs::path bad_summary = bad_root / "report" / veh / "summary.yaml";
  ASSERT_TRUE(fs::exists(bad_summary)) << readText(root / "bad.log");
  YamlMap bad_report = YamlMap::loadFile(bad_summary.string());
  EXPECT_EQ(bad_report.required<std::string>("result"), "failed");
  const std::string failure = bad_report.required<std::string>("failure");
  EXPECT_NE(failure.find(cause), std::string::npos) << failure;
  EXPECT_EQ(failure.find("interrupted"), std::string::npos) << failure;
  const std::string log = readText(root / "bad.log");
  EXPECT_NE(log.find("replay: FAILED: " + cause), std::string::npos) << log;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay");
  return RUN_ALL_TESTS();
}
