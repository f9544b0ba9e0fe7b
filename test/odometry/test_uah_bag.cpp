// `rosrun autocal uah --bag` on a bag recorded from the simulator (uah_bag.test): the live run of
// odometry_calibration_node is recorded by `rosbag record`; once it is DONE the test ends the
// recording (SIGINT, as Ctrl-C does), runs `uah --bag` on the bag and compares its result with the
// live node's odometry/<veh>.yaml and with the robot config's truth (the tolerances are the .test
// file's parameters). Then bad input, each on a copy of the same bag: missing file, not a bag, a
// truncated bag, a topic missing, an encoder reset, lengths that do not match the runs — each exit
// code 2 with a clear message and nothing written.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "autocal/odometry/calibration_file.h"
#include "autocal/sim/config.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

namespace fs = std::filesystem;
using autocal::CalibrationStatus;
using autocal::test::spinUntil;
using autocal::test::testParam;

struct Command {
  int code = -1;
  std::string out, err;
  double wall_s = 0;
};

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// Runs `BINARY ARGS`; its exit code, stdout and stderr.
Command runCommand(const std::string& binary, const std::string& args) {
  const std::string dir = fs::temp_directory_path() / "autocal_uah_bag_test_out";
  fs::create_directories(dir);
  const std::string out = dir + "/stdout", err = dir + "/stderr";
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system((binary + " " + args + " > " + out + " 2> " + err).c_str());
  Command c;
  c.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  c.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  c.out = slurp(out);
  c.err = slurp(err);
  return c;
}

/// Runs `uah ARGS`.
Command runUah(const std::string& args) { return runCommand(UAH_BINARY, args); }

/// The recorded bag and the live result, shared by the tests (one recorded run).
struct Recorded {
  std::string bag, veh, live_path;
  YAML::Node bag_result;
};
std::optional<Recorded> g_recorded;

/// A copy of `in` without `drop_topic`, and with the left encoder reset to 0 halfway when
/// `reset_left` (a driver restart).
void copyBag(const std::string& in, const std::string& out, const std::string& drop_topic,
             const std::string& reset_left) {
  rosbag::Bag src(in, rosbag::bagmode::Read), dst(out, rosbag::bagmode::Write);
  rosbag::View view(src);
  const ros::Time mid = view.getBeginTime() + (view.getEndTime() - view.getBeginTime()) * 0.5;
  std::optional<int> offset;
  for (const rosbag::MessageInstance& m : view) {
    if (m.getTopic() == drop_topic) continue;
    if (m.getTopic() == reset_left && m.getTime() > mid) {
      auto e = m.instantiate<autocal::dtmsg::WheelEncoderStamped>();
      if (!offset) offset = e->data;
      e->data -= *offset;
      dst.write(m.getTopic(), m.getTime(), *e, m.getConnectionHeader());
      continue;
    }
    dst.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
  }
}

/// A copy of `in` with one more zero command on `cmd_topic`, stamped 0 (sent at time 0 of the
/// clock) and recorded `late_s` after the first moving command's stamp: what the recorder makes
/// of the zero commands a node sends while the simulator's clock is still at 0, when its own clock
/// runs ahead (uah_bag.test once failed "pivot_left_stopped at 0.005 s: the recording has no
/// encoder readings over the motion").
void copyBagWithLateZeroCommand(const std::string& in, const std::string& out,
                                const std::string& cmd_topic, double late_s) {
  rosbag::Bag src(in, rosbag::bagmode::Read), dst(out, rosbag::bagmode::Write);
  bool inserted = false;
  for (const rosbag::MessageInstance& m : rosbag::View(src)) {
    dst.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    if (inserted || m.getTopic() != cmd_topic) continue;
    auto c = m.instantiate<autocal::dtmsg::WheelsCmdStamped>();
    if (c->vel_left == 0 && c->vel_right == 0) continue;
    const ros::Time recorded = c->header.stamp + ros::Duration(late_s);
    c->header.stamp = ros::Time(0);
    c->vel_left = c->vel_right = 0;
    dst.write(m.getTopic(), recorded, *c, m.getConnectionHeader());
    inserted = true;
  }
}

double relative(double a, double b) { return a / b - 1; }

int liveAcceptedRuns(const std::string& live_path) {
  return YAML::LoadFile(live_path)["inputs"]["straight_runs_accepted"].as<int>();
}

TEST(UahBag, RecomputesTheLiveRunFromItsBag) {
  const std::string veh = testParam<std::string>("veh");
  const std::string root = testParam<std::string>("calibration_root");
  const std::string bag = testParam<std::string>("bag");
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  // An earlier test run's files (the node writes its file only at its end, a minute from now).
  autocal::test::removeTree(root);

  ros::NodeHandle nh(veh);
  std::optional<CalibrationStatus> end;
  ros::Subscriber status_sub = nh.subscribe<CalibrationStatus>(
      "calibration/status", 1000, [&](const CalibrationStatus::ConstPtr& m) {
        if (m->state == CalibrationStatus::STATE_FAILED ||
            (m->phase.rfind("odometry/", 0) == 0 && m->state == CalibrationStatus::STATE_DONE))
          end = *m;
      });
  ASSERT_TRUE(spinUntil([&] { return end.has_value(); }, testParam<double>("wall_budget_s")))
      << "no DONE or FAILED from odometry_calibration_node";
  ASSERT_EQ(end->state, CalibrationStatus::STATE_DONE) << end->phase << ": " << end->failure_reason;
  const std::string live_path = autocal::odometry::odometryCalibrationPath(root, veh);
  ASSERT_EQ(end->text, "wrote " + live_path);

  // End the recording as Ctrl-C does: rosbag closes the bag (writes its index) and renames it
  // from .active. Half a second of sim time first, so that the DONE status is in the bag.
  autocal::test::spinUntilSimTime(ros::Time::now().toSec() + 0.5, 10);
  const int pid = autocal::ros_layer::nodePid(testParam<std::string>("recorder"));
  ASSERT_GT(pid, 0) << "rosbag record is not running";
  ASSERT_EQ(::kill(pid, SIGINT), 0);
  ASSERT_TRUE(spinUntil([&] { return fs::exists(bag) && !fs::exists(bag + ".active"); }, 30))
      << "rosbag record did not close " << bag;
  std::cout << "recorded " << bag << " (" << fs::file_size(bag) / 1024 << " KiB)" << std::endl;

  const std::string out_path = root + "/from_bag/odometry/" + veh + ".yaml";
  const Command c = runUah("--bag " + bag + " --veh " + veh + " --out " + out_path);
  ASSERT_EQ(c.code, 0) << c.err;
  std::cout << "uah --bag (" << c.wall_s << " s):\n" << c.out << c.err << std::endl;
  const YAML::Node b = YAML::Load(c.out);
  const YAML::Node live = YAML::LoadFile(live_path);
  EXPECT_EQ(b["straight_runs"]["lengths"].as<std::string>(), "recorded");
  EXPECT_EQ(b["recorded_run"].as<std::string>(), "done");
  EXPECT_EQ(b["turns"].size(), 5u);  // 2 pivots on each wheel, 1 spin
  // The straight runs the live node accepted, and their pulses and heading (the node logs them).
  int accepted = 0;
  for (const auto& run : b["straight_runs"]["runs"]) accepted += run["accepted"].as<bool>();
  EXPECT_EQ(accepted, liveAcceptedRuns(live_path));

  const double Ed = b["Ed"].as<double>(), wheelbase = b["wheelbase_m"].as<double>(),
               cL = b["left_m_per_pulse"].as<double>(), cR = b["right_m_per_pulse"].as<double>();
  const double d_Ed = relative(Ed, live["Ed"].as<double>());
  const double d_b = relative(wheelbase, live["b"].as<double>());
  const double d_cL = relative(cL, live["left_m_per_pulse"].as<double>());
  const double d_cR = relative(cR, live["right_m_per_pulse"].as<double>());
  const double rad_per_pulse = 2 * M_PI / robot.encoder_resolution;
  const double e_Ed = relative(Ed, robot.wheel_radius_right / robot.wheel_radius_left);
  const double e_b = relative(wheelbase, robot.wheelbase);
  const double e_cR = relative(cR, rad_per_pulse * robot.wheel_radius_right);
  const double e_cL = relative(cL, rad_per_pulse * robot.wheel_radius_left);
  std::printf(
      "bag vs live: Ed %+.4f %%, b %+.4f %%, c_L %+.4f %%, c_R %+.4f %%\n"
      "bag vs truth: Ed %+.4f %%, b %+.4f %%, c_L %+.4f %%, c_R %+.4f %%\n"
      "live: Ed %.6f, b %.6f m, c_L %.6f mm, c_R %.6f mm\n",
      100 * d_Ed, 100 * d_b, 100 * d_cL, 100 * d_cR, 100 * e_Ed, 100 * e_b, 100 * e_cL, 100 * e_cR,
      live["Ed"].as<double>(), live["b"].as<double>(), 1000 * live["left_m_per_pulse"].as<double>(),
      1000 * live["right_m_per_pulse"].as<double>());
  EXPECT_LT(std::abs(d_Ed), testParam<double>("max_live_Ed_difference"));
  EXPECT_LT(std::abs(d_b), testParam<double>("max_live_wheelbase_difference"));
  EXPECT_LT(std::abs(d_cL), testParam<double>("max_live_m_per_pulse_difference"));
  EXPECT_LT(std::abs(d_cR), testParam<double>("max_live_m_per_pulse_difference"));
  EXPECT_LT(std::abs(e_Ed), testParam<double>("max_Ed_error"));
  EXPECT_LT(std::abs(e_b), testParam<double>("max_wheelbase_error"));
  EXPECT_LT(std::abs(e_cR), testParam<double>("max_m_per_pulse_error"));
  EXPECT_LT(std::abs(e_cL), testParam<double>("max_m_per_pulse_error"));

  // --out wrote the odometry file with the same figures.
  const YAML::Node written = YAML::LoadFile(out_path);
  EXPECT_EQ(written["method"].as<std::string>(), "uah");
  EXPECT_EQ(written["vehicle"].as<std::string>(), veh);
  EXPECT_NEAR(written["Ed"].as<double>(), Ed, 1e-9);
  EXPECT_NEAR(written["right_m_per_pulse"].as<double>(), cR, 1e-12);

  // The same lengths given on the command line give the same result; one length for every run
  // (the nominal 3.0 m instead of the true ~3.05) is every run's, and c_R is the accepted runs'
  // mean of it per pulse (the forward run, faster over its second half, coasts some 2 cm further
  // than the one back, so one length for both can put them over max_disagreement apart).
  std::string lengths;
  double mean_length = 0;
  for (const auto& run : b["straight_runs"]["runs"]) {
    lengths += (lengths.empty() ? "" : ",") + run["length_m"].as<std::string>();
    mean_length += run["length_m"].as<double>() / b["straight_runs"]["runs"].size();
  }
  const Command given =
      runUah("--bag " + bag + " --veh " + veh + " --straight-length-m " + lengths);
  ASSERT_EQ(given.code, 0) << given.err;
  const YAML::Node g = YAML::Load(given.out);
  EXPECT_EQ(g["straight_runs"]["lengths"].as<std::string>(), "given");
  EXPECT_NEAR(g["right_m_per_pulse"].as<double>(), cR, 1e-12);
  const Command nominal = runUah("--bag " + bag + " --veh " + veh + " --straight-length-m 3.0");
  ASSERT_EQ(nominal.code, 0) << nominal.err;
  const YAML::Node n = YAML::Load(nominal.out);
  double per_pulse = 0;
  int kept = 0;
  for (const auto& run : n["straight_runs"]["runs"]) {
    EXPECT_EQ(run["length_m"].as<double>(), 3.0);
    if (!run["accepted"].as<bool>()) continue;
    per_pulse += 3.0 / run["right_pulses"].as<double>(), ++kept;
  }
  ASSERT_GT(kept, 0);
  EXPECT_NEAR(n["right_m_per_pulse"].as<double>(), per_pulse / kept, 1e-6 * cR);
  EXPECT_NEAR(n["right_m_per_pulse"].as<double>() / cR, 3.0 / mean_length, 0.01);
  g_recorded = Recorded{bag, veh, live_path, b};

  // `replay` recomputes the run from the same bag with no master: the recording holds the odometry
  // stage alone, which it replays as `uah --bag` does, and it writes the file and the run's report.
  const std::string replay_root = root + "/replay";
  const Command rp =
      runCommand(REPLAY_BINARY, bag + " --veh " + veh + " --calibration-root " + replay_root);
  ASSERT_EQ(rp.code, 0) << rp.out << rp.err;
  std::cout << "replay (" << rp.wall_s << " s):\n" << rp.out << std::endl;
  const YAML::Node replayed =
      YAML::LoadFile(autocal::odometry::odometryCalibrationPath(replay_root, veh));
  EXPECT_NEAR(replayed["Ed"].as<double>(), Ed, 1e-9);
  EXPECT_NEAR(replayed["b"].as<double>(), wheelbase, 1e-9);
  EXPECT_NEAR(replayed["right_m_per_pulse"].as<double>(), cR, 1e-12);
  const YAML::Node summary = YAML::LoadFile(replay_root + "/report/" + veh + "/summary.yaml");
  EXPECT_EQ(summary["result"].as<std::string>(), "success");
  EXPECT_EQ(summary["replay_of"].as<std::string>(), bag);
  EXPECT_EQ(summary["stages"]["odometry"]["state"].as<std::string>(), "done");
  EXPECT_FALSE(summary["stages"]["camera"]);

  // A zero command of time 0 (stamp 0) recorded after the first motion began is still the
  // command before it: the same result (a stamp of 0 from a publisher that stamps is time 0, not
  // "no stamp, take the record time").
  const std::string late_zero = root + "/late_zero.bag";
  copyBagWithLateZeroCommand(bag, late_zero, "/" + veh + "/wheels_driver_node/wheels_cmd", 0.005);
  const Command z = runUah("--bag " + late_zero + " --veh " + veh);
  ASSERT_EQ(z.code, 0) << z.err;
  EXPECT_EQ(YAML::Load(z.out)["Ed"].as<double>(), Ed);
  EXPECT_EQ(YAML::Load(z.out)["right_m_per_pulse"].as<double>(), cR);
}

struct BadCase {
  std::string label, args, message;
};

TEST(UahBag, BadInputIsRefusedAndNothingWritten) {
  ASSERT_TRUE(g_recorded.has_value()) << "no bag was recorded (see the first test)";
  const Recorded& r = *g_recorded;
  const std::string dir = fs::temp_directory_path() / "autocal_uah_bag_test_bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string ns = "/" + r.veh + "/";

  const std::string not_a_bag = dir + "/not_a_bag.bag";
  std::ofstream(not_a_bag) << "method: uah\n";
  // The first half of the bag's bytes: what a recording killed without a chance to close leaves.
  const std::string truncated = dir + "/truncated.bag";
  {
    const std::string bytes = slurp(r.bag);
    std::ofstream(truncated, std::ios::binary).write(bytes.data(), bytes.size() / 2);
  }
  const std::string no_range = dir + "/no_range.bag";
  copyBag(r.bag, no_range, ns + "front_center_tof_driver_node/range", "");
  const std::string reset = dir + "/encoder_reset.bag";
  copyBag(r.bag, reset, "", ns + "left_wheel_encoder_node/tick");

  const std::string veh = " --veh " + r.veh;
  const std::vector<BadCase> cases = {
      {"missing file", "--bag " + dir + "/none.bag" + veh, "no such file"},
      {"not a bag", "--bag " + not_a_bag + veh, "cannot open the bag"},
      {"truncated", "--bag " + truncated + veh, "truncated"},
      {"missing topic", "--bag " + no_range + veh, ns + "front_center_tof_driver_node/range"},
      {"wrong vehicle", "--bag " + r.bag + " --veh otherbot", "/otherbot/"},
      {"encoder reset", "--bag " + reset + veh, "encoder jump"},
      {"three lengths for two runs", "--bag " + r.bag + veh + " --straight-length-m 3,3,3",
       "lengths were given"},
  };
  for (const BadCase& c : cases) {
    const std::string out = dir + "/odometry/" + r.veh + ".yaml";
    const Command cmd = runUah(c.args + " --out " + out);
    std::cout << "[" << c.label << "] exit " << cmd.code << ", " << cmd.wall_s << " s: " << cmd.err;
    EXPECT_EQ(cmd.code, 2) << c.label << ": " << cmd.err;
    EXPECT_NE(cmd.err.find(c.message), std::string::npos) << c.label << ": " << cmd.err;
    EXPECT_TRUE(cmd.out.empty()) << c.label << ": " << cmd.out;
    EXPECT_FALSE(fs::exists(out)) << c.label << ": wrote " << out;
  }
  // Data that do not determine a result is a failed calibration (1): a length far from what the
  // pulses say (a run cut short, a wrong measurement).
  const std::string out = dir + "/odometry/" + r.veh + ".yaml";
  const Command short_length =
      runUah("--bag " + r.bag + veh + " --straight-length-m 1.5 --out " + out);
  std::cout << "[length far from the pulses] exit " << short_length.code << ": "
            << short_length.err;
  EXPECT_EQ(short_length.code, 1) << short_length.err;
  EXPECT_NE(short_length.err.find("far from"), std::string::npos) << short_length.err;
  EXPECT_FALSE(fs::exists(out));
  // A bad command line is a usage error (64).
  const Command usage = runUah("--bag " + r.bag);
  EXPECT_EQ(usage.code, 64) << usage.err;
  EXPECT_NE(usage.err.find("--veh"), std::string::npos) << usage.err;
  // A length in millimetres or centimetres is a bad configuration (3), refused before the bag is
  // read, with the likely unit.
  const std::vector<BadCase> slips = {
      {"radius in mm", "--bag " + r.bag + veh + " --wheel-radius-m 31.8", "looks like millimetres"},
      {"wheelbase in cm", "--bag " + r.bag + veh + " --wheelbase-m 10", "looks like centimetres"},
  };
  for (const BadCase& c : slips) {
    const Command cmd = runUah(c.args + " --out " + out);
    EXPECT_EQ(cmd.code, 3) << c.label << ": " << cmd.err;
    EXPECT_NE(cmd.err.find(c.message), std::string::npos) << c.label << ": " << cmd.err;
    EXPECT_FALSE(fs::exists(out)) << c.label;
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_uah_bag");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
