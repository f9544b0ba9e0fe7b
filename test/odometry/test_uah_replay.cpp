// odometry::replayUah (the passive mode, paper 002 §2 from a recording) on runs of UahRun on the
// simulator's core: the shared loop (test/support/odometry_in_sim.h) records what a bag of the
// node's run would hold, the replay recomputes the result from it and is compared with the live
// run's result and with the robot config's truth (the odometry stage's accuracy bounds). Then
// recordings that cannot carry the result: each an InputError with its reason.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "autocal/errors.h"
#include "autocal/odometry/uah_replay.h"
#include "support/odometry_in_sim.h"

using namespace autocal;
using odometry::UahExperiment;

namespace {

odometry::UahRunOptions optionsFor(const test::OdometryTestRobot& r) {
  odometry::UahRunOptions o;
  o.nominal = odometry::DiffDriveParams::fromWheel(
      2 * r.nominal_radius_m, r.robot.encoder_resolution, r.nominal_wheelbase_m);
  return o;
}

struct Recorded {
  test::UahInSim live;
  odometry::UahRecording recording;
  odometry::UahRunOptions options;
};

/// The run of `r` in the odometry world, recorded; `transport`: through the robot's late links.
Recorded recordRun(const test::OdometryTestRobot& r, bool transport = false) {
  Recorded out;
  sim::Simulation simulation(
      r.robot,
      sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world_odometry.yaml"),
      sim::SimulationOptions());
  std::mt19937_64 rng(1);
  test::UahSensorHooks hooks;
  hooks.recording = &out.recording;
  hooks.transport = transport;
  out.options = optionsFor(r);
  out.live = test::runUahInSim(simulation, out.options, rng, 900, hooks);
  return out;
}

const Recorded& defaultRun() {
  static const Recorded run = recordRun(test::odometryTestRobots().front());
  return run;
}

odometry::UahReplayOptions replayOptions(const Recorded& r) {
  odometry::UahReplayOptions o;
  o.run = r.options;
  return o;
}

class UahReplayRobots : public ::testing::TestWithParam<int> {};

TEST_P(UahReplayRobots, RecomputesTheLiveResultFromTheRecording) {
  const test::OdometryTestRobot robot = test::odometryTestRobots().at(GetParam());
  const Recorded rec = GetParam() == 0 ? defaultRun() : recordRun(robot);
  ASSERT_TRUE(rec.live.done) << rec.live.failure;
  const odometry::UahReplayResult replay = odometry::replayUah(rec.recording, replayOptions(rec));
  const odometry::UahResult& live = rec.live.result;
  const odometry::UahResult& bag = replay.result;
  EXPECT_EQ(replay.recorded_outcome, "done");
  EXPECT_EQ(replay.lengths_source, "recorded");
  ASSERT_EQ(replay.turns.size(), rec.live.turns.size());
  for (size_t i = 0; i < replay.turns.size(); ++i) {
    if (std::getenv("AUTOCAL_TRACE"))
      std::printf(
          "turn %zu: live %.3f pulses turned, %d readings (%d invalid); replay %.3f, %d (%d), "
          "motion %.3f-%.3f-%.3f\n",
          i, rec.live.turns[i].pulses_turned, rec.live.turns[i].range_readings,
          rec.live.turns[i].invalid_readings, replay.turns[i].pulses_turned,
          replay.turns[i].range_readings, replay.turns[i].invalid_readings,
          replay.motions[i].start_s, replay.motions[i].stop_s, replay.motions[i].end_s);
    EXPECT_EQ(replay.turns[i].experiment, rec.live.turns[i].experiment);
    // The same readings, cut where the recorded commands and status say: the same round.
    EXPECT_NEAR(replay.turns[i].detection.pulses_per_round,
                rec.live.turns[i].detection.pulses_per_round, 1e-9)
        << odometry::name(replay.turns[i].experiment);
  }
  ASSERT_EQ(replay.straight_runs.size(), rec.live.straight_runs.size());
  for (size_t i = 0; i < replay.straight_runs.size(); ++i) {
    if (std::getenv("AUTOCAL_TRACE"))
      std::printf("straight %zu: live %.0f pulses, %.3f deg; replay %.0f, %.3f deg\n", i,
                  rec.live.straight_runs[i].right_pulses,
                  rec.live.straight_runs[i].max_heading_deviation_rad * 180 / M_PI,
                  replay.straight_runs[i].right_pulses,
                  replay.straight_runs[i].max_heading_deviation_rad * 180 / M_PI);
    EXPECT_EQ(replay.straight_runs[i].right_pulses, rec.live.straight_runs[i].right_pulses);
    EXPECT_NEAR(replay.straight_runs[i].max_heading_deviation_rad,
                rec.live.straight_runs[i].max_heading_deviation_rad, 1e-12);
    // The duties that held it straight, from the recorded commands: the live run's, as the trim
    // the stage compares with the wheel stage's is made of them.
    const odometry::StraightRun& l = rec.live.straight_runs[i];
    const odometry::StraightRun& b = replay.straight_runs[i];
    if (std::getenv("AUTOCAL_TRACE"))
      std::printf("straight %zu duties: live %.6f/%.6f, replay %.6f/%.6f\n", i, l.mean_left_duty,
                  l.mean_right_duty, b.mean_left_duty, b.mean_right_duty);
    EXPECT_EQ(b.forward, l.forward);
    EXPECT_GT(b.mean_left_duty, 0);
    EXPECT_NEAR(b.mean_left_duty, l.mean_left_duty, 1e-4);
    EXPECT_NEAR(b.mean_right_duty, l.mean_right_duty, 1e-4);
  }
  const wheels::KinematicsParams k;
  const double live_trim =
      odometry::straightRunTrim(rec.live.straight_runs, live.straight.accepted_runs, k);
  const double replay_trim =
      odometry::straightRunTrim(replay.straight_runs, bag.straight.accepted_runs, k);
  std::printf("straight runs' trim: live %.6f, replay %.6f\n", live_trim, replay_trim);
  ASSERT_TRUE(std::isfinite(live_trim));
  // The second halves are cut at a sample either side: runs gave 0.00001-0.00005 apart.
  EXPECT_NEAR(replay_trim, live_trim, 2e-4);
  const auto rel = [](double a, double b) { return a / b - 1; };
  const double c = 2 * M_PI / robot.robot.encoder_resolution;
  std::printf(
      "[%s] replay vs live: Ed %+.4f %%, b %+.4f %%, c_L %+.4f %%, c_R %+.4f %%; vs truth: Ed "
      "%+.3f %%, b %+.3f %%, c_R %+.3f %%\n",
      robot.label.c_str(), 100 * rel(bag.ed.Ed, live.ed.Ed),
      100 * rel(bag.calibrated.wheelbase_m, live.calibrated.wheelbase_m),
      100 * rel(bag.calibrated.left_m_per_pulse, live.calibrated.left_m_per_pulse),
      100 * rel(bag.calibrated.right_m_per_pulse, live.calibrated.right_m_per_pulse),
      100 * rel(bag.ed.Ed, test::trueEd(robot.robot)),
      100 * rel(bag.calibrated.wheelbase_m, robot.robot.wheelbase),
      100 * rel(bag.calibrated.right_m_per_pulse, c * robot.robot.wheel_radius_right));
  // On the simulator's core the recording holds exactly what the live run saw: the same result.
  EXPECT_LT(std::abs(rel(bag.ed.Ed, live.ed.Ed)), 1e-12);
  EXPECT_LT(std::abs(rel(bag.calibrated.wheelbase_m, live.calibrated.wheelbase_m)), 1e-12);
  EXPECT_LT(std::abs(rel(bag.calibrated.right_m_per_pulse, live.calibrated.right_m_per_pulse)),
            1e-12);
  EXPECT_LT(std::abs(rel(bag.calibrated.left_m_per_pulse, live.calibrated.left_m_per_pulse)),
            1e-12);
  EXPECT_LT(std::abs(rel(bag.ed.Ed, test::trueEd(robot.robot))), 0.002);
  EXPECT_LT(std::abs(rel(bag.calibrated.wheelbase_m, robot.robot.wheelbase)), 0.005);
  EXPECT_LT(std::abs(rel(bag.calibrated.right_m_per_pulse, c * robot.robot.wheel_radius_right)),
            0.005);
  EXPECT_LT(std::abs(rel(bag.calibrated.left_m_per_pulse, c * robot.robot.wheel_radius_left)),
            0.005);
}

INSTANTIATE_TEST_SUITE_P(OdometryTestRobots, UahReplayRobots, ::testing::Values(0, 1, 2, 3));

// A robot whose turns leave it off its heading turns back before its straight runs: the replay
// leaves those turns out of the experiments and gets the live run's turns and runs.
TEST(UahReplay, TurnsBackToTheHeadingAreLeftOut) {
  test::OdometryTestRobot robot = test::odometryTestRobots().front();
  robot.robot = test::stickyLateRobot();
  const Recorded rec = recordRun(robot, true);
  ASSERT_TRUE(rec.live.done) << rec.live.failure;
  ASSERT_GE(rec.live.face_turns, 1);
  const odometry::UahReplayResult replay = odometry::replayUah(rec.recording, replayOptions(rec));
  const auto faces = std::count_if(replay.motions.begin(), replay.motions.end(), [](const auto& m) {
    return m.experiment == UahExperiment::kFace;
  });
  EXPECT_EQ(faces, rec.live.face_turns);
  ASSERT_EQ(replay.turns.size(), rec.live.turns.size());
  for (size_t i = 0; i < replay.turns.size(); ++i) {
    EXPECT_EQ(replay.turns[i].experiment, rec.live.turns[i].experiment);
  }
  ASSERT_EQ(replay.straight_runs.size(), rec.live.straight_runs.size());
  for (size_t i = 0; i < replay.straight_runs.size(); ++i) {
    EXPECT_EQ(replay.straight_runs[i].right_pulses, rec.live.straight_runs[i].right_pulses);
  }
  EXPECT_NEAR(replay.result.calibrated.wheelbase_m / rec.live.result.calibrated.wheelbase_m, 1.0,
              1e-3);
}

TEST(UahReplay, GivenLengthsReplaceTheRecordedOnes) {
  const Recorded& rec = defaultRun();
  odometry::UahReplayOptions o = replayOptions(rec);
  for (const auto& run : rec.live.straight_runs) o.straight_lengths_m.push_back(run.length_m);
  const auto same = odometry::replayUah(rec.recording, o);
  EXPECT_EQ(same.lengths_source, "given");
  const auto recorded = odometry::replayUah(rec.recording, replayOptions(rec));
  EXPECT_DOUBLE_EQ(same.result.calibrated.right_m_per_pulse,
                   recorded.result.calibrated.right_m_per_pulse);
  o.straight_lengths_m = {1.5};  // one length for every run; far from the pulses: refused
  EXPECT_THROW(odometry::replayUah(rec.recording, o), CalibrationError);
  o.straight_lengths_m = {3.0, 3.0, 3.0};
  EXPECT_THROW(odometry::replayUah(rec.recording, o), InputError);
}

/// The reason of the InputError the replay throws on `rec` ("" when it does not).
std::string inputError(const odometry::UahRecording& rec, const odometry::UahReplayOptions& o) {
  try {
    odometry::replayUah(rec, o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A recording of the whole run (camera and wheel stages, then UAH) holds the earlier stages'
// motions on the same wheels_cmd, under their own status phases: they are left out, and the
// result is the UAH run's alone.
TEST(UahReplay, EarlierStagesMotionsInTheRecordingAreLeftOut) {
  const Recorded& run = defaultRun();
  const odometry::UahReplayOptions o = replayOptions(run);
  const odometry::UahReplayResult alone = odometry::replayUah(run.recording, o);
  odometry::UahRecording rec = run.recording;
  const double shift_s = 20.0;  // the earlier stages take the first 20 s
  for (auto& e : rec.encoders) e.stamp_s += shift_s;
  for (auto& r : rec.ranges) r.stamp_s += shift_s;
  for (auto& c : rec.commands) c.stamp_s += shift_s;
  for (auto& s : rec.statuses) s.stamp_s += shift_s;
  for (auto& l : rec.lengths) l.stamp_s += shift_s;
  // A camera-stage pulse and a wheel-stage drive, with their statuses (their encoder readings do
  // not concern the UAH run).
  using Rec = odometry::UahRecording;
  std::vector<Rec::Command> earlier = {
      {1.0, 0.0, 0.3}, {1.1, 0.0, 0.0}, {5.0, 0.3, 0.3}, {9.0, 0.0, 0.0}};
  rec.commands.insert(rec.commands.begin(), earlier.begin(), earlier.end());
  std::vector<Rec::Status> phases(2);
  phases[0].stamp_s = 1.0;
  phases[0].phase = "camera/sweep";
  phases[1].stamp_s = 5.0;
  phases[1].phase = "wheels/drive";
  rec.statuses.insert(rec.statuses.begin(), phases.begin(), phases.end());
  const odometry::UahReplayResult whole = odometry::replayUah(rec, o);
  EXPECT_EQ(whole.earlier_stage_motions, 2);
  EXPECT_EQ(whole.motions.size(), alone.motions.size());
  // The same result up to the samples that the shifted stamps' rounding moves across a motion's
  // boundary (the shift alone changes Ed by about 2e-4).
  EXPECT_NEAR(whole.result.ed.Ed, alone.result.ed.Ed, 1e-3);
  EXPECT_NEAR(whole.result.calibrated.wheelbase_m, alone.result.calibrated.wheelbase_m, 1e-4);
  EXPECT_NEAR(whole.result.calibrated.right_m_per_pulse / alone.result.calibrated.right_m_per_pulse,
              1.0, 1e-3);
  {
    odometry::UahRecording shifted = run.recording;  // the shift alone, for the comment above
    for (auto& e : shifted.encoders) e.stamp_s += shift_s;
    for (auto& r : shifted.ranges) r.stamp_s += shift_s;
    for (auto& c : shifted.commands) c.stamp_s += shift_s;
    for (auto& st : shifted.statuses) st.stamp_s += shift_s;
    for (auto& l : shifted.lengths) l.stamp_s += shift_s;
    const odometry::UahReplayResult moved = odometry::replayUah(shifted, o);
    EXPECT_NEAR(whole.result.ed.Ed, moved.result.ed.Ed, 1e-12);
    EXPECT_NEAR(whole.result.calibrated.wheelbase_m, moved.result.calibrated.wheelbase_m, 1e-12);
  }
  // Without any odometry experiment recorded, nothing is left: refused.
  odometry::UahRecording none = rec;
  none.statuses.resize(2);
  EXPECT_THROW(odometry::replayUah(none, o), autocal::InputError);
}

TEST(UahReplay, RecordingsThatCannotCarryTheResultAreRefused) {
  const Recorded& run = defaultRun();
  const odometry::UahReplayOptions o = replayOptions(run);
  {
    odometry::UahRecording rec = run.recording;
    rec.statuses.clear();
    EXPECT_NE(inputError(rec, o).find("no calibration status"), std::string::npos);
  }
  {
    // The status says the second experiment pivoted on the stopped left wheel, the commands
    // drive the left wheel.
    odometry::UahRecording rec = run.recording;
    for (auto& s : rec.statuses) {
      if (s.phase == "odometry/pivot_right_stopped") s.phase = "odometry/pivot_left_stopped";
    }
    EXPECT_NE(inputError(rec, o).find("drive something else"), std::string::npos)
        << inputError(rec, o);
  }
  {
    // A recording that ends before the spin.
    odometry::UahRecording rec = run.recording;
    const double spin_s = [&] {
      for (const auto& s : rec.statuses)
        if (s.phase == "odometry/spin") return s.stamp_s;
      return 1e9;
    }();
    auto cut = [&](auto& v) {
      v.erase(
          std::remove_if(v.begin(), v.end(), [&](const auto& x) { return x.stamp_s >= spin_s; }),
          v.end());
    };
    cut(rec.encoders), cut(rec.ranges), cut(rec.commands), cut(rec.statuses), cut(rec.lengths);
    EXPECT_NE(inputError(rec, o).find("no spin"), std::string::npos) << inputError(rec, o);
  }
  {
    // An encoder reset halfway.
    odometry::UahRecording rec = run.recording;
    const size_t half = rec.encoders.size() / 2;
    const auto offset = rec.encoders[half];
    for (size_t i = half; i < rec.encoders.size(); ++i) {
      rec.encoders[i].left -= offset.left;
      rec.encoders[i].right -= offset.right;
    }
    EXPECT_NE(inputError(rec, o).find("encoder jump"), std::string::npos) << inputError(rec, o);
  }
  {
    // No length recorded for the last straight run, none given.
    odometry::UahRecording rec = run.recording;
    rec.lengths.pop_back();
    EXPECT_NE(inputError(rec, o).find("has no length"), std::string::npos) << inputError(rec, o);
  }
}

}  // namespace
