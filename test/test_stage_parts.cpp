// The parts the driving stages share: EncoderTracker (sensors.h), SettleRule, MotionClock,
// RunWatch, followRate, stallOf, EncoderDrive (motion.h) and StatusThrottle.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/status_throttle.h"

namespace autocal {
namespace {

TEST(EncoderTracker, UnwrapsThirtyTwoBitCountsAndKeepsTheRawReading) {
  EncoderTracker e;
  const std::int32_t top = std::numeric_limits<std::int32_t>::max();
  EXPECT_TRUE(e.add(1.0, top - 2, 10).first);
  const EncoderTracker::Step s = e.add(1.1, top, 10);
  EXPECT_DOUBLE_EQ(s.left_ticks, 2);
  const EncoderTracker::Step wrapped = e.add(1.2, std::numeric_limits<std::int32_t>::min() + 3, 7);
  EXPECT_DOUBLE_EQ(wrapped.left_ticks, 4);  // top -> top + 4, wrapped around
  EXPECT_DOUBLE_EQ(wrapped.right_ticks, -3);
  EXPECT_DOUBLE_EQ(e.left(), 6);
  EXPECT_DOUBLE_EQ(e.right(), -3);
  EXPECT_EQ(e.rawLeft(), std::numeric_limits<std::int32_t>::min() + 3);
  EXPECT_EQ(e.rawRight(), 7);
  EXPECT_DOUBLE_EQ(e.stampS(), 1.2);
}

TEST(EncoderTracker, IgnoresOlderReadingsAndTracksEachWheelsLastChange) {
  EncoderTracker e;
  EXPECT_FALSE(e.valid());
  e.add(1.0, 0, 0);
  e.add(2.0, 5, 0);
  EXPECT_FALSE(e.add(1.5, 100, 100).accepted);
  EXPECT_EQ(e.rawLeft(), 5);
  e.add(3.0, 5, 1);
  EXPECT_DOUBLE_EQ(e.lastChangeS(0), 2.0);
  EXPECT_DOUBLE_EQ(e.lastChangeS(1), 3.0);
  EXPECT_DOUBLE_EQ(e.lastChangeS(), 3.0);
  e.add(4.0, 5, 1);  // same counts, same stamp accepted
  EXPECT_DOUBLE_EQ(e.lastChangeS(), 3.0);
  EXPECT_TRUE(e.stillSince(3.0, 1.0));
  EXPECT_FALSE(e.stillSince(3.0, 1.1));
  EXPECT_FALSE(e.stillSince(4.5, 0.0));  // no reading since 4.5
}

TEST(EncoderTracker, JumpIsNamedBeyondTheRateOverTheLongerOfTheIntervalAndTheWindow) {
  EncoderTracker e;
  e.add(0.0, 0, 0);
  // 1000 pulses/s over max(0.01, 0.1) s + 5 = 105 ticks allowed.
  EXPECT_TRUE(EncoderTracker::jump(e.add(0.01, 105, -105), 1000, 0.1).empty());
  const std::string j = EncoderTracker::jump(e.add(0.02, 105 + 106, -105), 1000, 0.1);
  EXPECT_NE(j.find("encoder jump: left 106, right 0 ticks in 0.01 s"), std::string::npos) << j;
}

TEST(SettleRule, SettlesOnStillEncodersAfterTheMinimumOrAtTheMaximum) {
  const SettleRule rule{0.3, 0.1, 2.0};
  EncoderTracker e;
  e.add(0.0, 0, 0);
  e.add(1.0, 10, 10);  // the stop at 1.0: still moving
  EXPECT_FALSE(rule.settled(1.0, 1.1, e));
  e.add(1.15, 12, 12);
  e.add(1.25, 12, 12);
  EXPECT_FALSE(rule.settled(1.0, 1.25, e));  // still for 0.1 s, but before settle_s
  e.add(1.3, 12, 12);
  EXPECT_TRUE(rule.settled(1.0, 1.3, e));
  e.add(1.4, 13, 12);  // creeps on
  EXPECT_FALSE(rule.settled(1.0, 2.9, e));
  EXPECT_TRUE(rule.settled(1.0, 3.0, e));  // max_settle_s whatever the encoders say
}

TEST(MotionClock, StartsAtTheFirstUpdateAfterAReset) {
  MotionClock c;
  EXPECT_TRUE(c.started());
  c.reset(5.0);
  EXPECT_FALSE(c.started());
  EXPECT_DOUBLE_EQ(c.startS(), 5.0);
  EXPECT_TRUE(c.start(5.5));
  EXPECT_FALSE(c.start(6.0));
  EXPECT_DOUBLE_EQ(c.elapsedS(6.0), 0.5);
}

TEST(FollowRate, RaisesASlowWheelsDutyLowersAFastOnesWithinItsBounds) {
  EXPECT_DOUBLE_EQ(followRate(0.2, 50, 100, 0.4, 0.5, 1.0), 0.2 + 0.4 * 0.5 * 0.5);
  EXPECT_DOUBLE_EQ(followRate(0.2, 200, 100, 0.4, 0.5, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(followRate(0.5, 0, 100, 10, 1, 0.6), 0.6);
}

TEST(StallOf, CountsFromTheLaterOfTheWheelsLastChangeAndTheMotionsStart) {
  EncoderTracker e;
  e.add(0.0, 0, 0);
  e.add(1.0, 1, 0);
  MotionClock c;
  c.reset(0.5);
  c.start(0.5);
  EXPECT_TRUE(stallOf(0, e, c, 1.9, 1.0, 0.3).empty());
  EXPECT_TRUE(stallOf(1, e, c, 1.5, 1.0, 0.3).empty());
  const std::string s = stallOf(1, e, c, 1.6, 1.0, 0.3);
  EXPECT_EQ(s,
            "the right wheel has not moved for 1.1 s at duty 0.3 (the robot stalled: blocked, "
            "or a motor fault)");
}

TEST(RunWatch, ClampsTheStepAndFailsOnTimeThenOnMissingThenOnSilentEncoders) {
  RunWatch w;
  EncoderTracker e;
  EXPECT_DOUBLE_EQ(w.tick(10.0), 0.0);  // the clock starts at the first update
  EXPECT_NEAR(w.tick(10.05), 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(w.tick(11.0), 0.2);  // one late update is not one huge step
  EXPECT_DOUBLE_EQ(w.elapsedS(), 1.0);
  // No reading yet: the stage waits until encoder_timeout_s from its start, and for more than
  // kSilentUpdates updates without one (one long gap is a node that was not scheduled).
  EXPECT_EQ(w.failure(11.0, e, true, 0, 3.0, "UAH run", "spin"), "");
  EXPECT_EQ(w.tick(13.5), 0.2);
  EXPECT_EQ(w.failure(13.5, e, true, 0, 3.0, "UAH run", "spin"), "");
  for (int i = 0; i < RunWatch::kSilentUpdates; ++i) w.tick(13.5);
  EXPECT_EQ(w.failure(13.5, e, true, 0, 3.0, "UAH run", "spin"), "no encoder readings");
  w.noteEncoders();
  e.add(11.0, 0, 0);
  EXPECT_EQ(w.failure(13.5, e, true, 0, 3.0, "UAH run", "spin"), "");
  w.tick(14.5);
  EXPECT_EQ(w.failure(14.5, e, true, 0, 3.0, "UAH run", "spin"), "");
  for (int i = 0; i < RunWatch::kSilentUpdates; ++i) w.tick(14.5);
  EXPECT_EQ(w.failure(14.5, e, false, 0, 3.0, "UAH run", "spin"), "");  // standing: no reading due
  EXPECT_EQ(w.failure(14.5, e, true, 0, 3.0, "UAH run", "spin"),
            "the encoders went silent for 3.5 s");
  EXPECT_EQ(w.failure(14.5, e, true, 4.0, 3.0, "UAH run", "spin"),
            "the UAH run took longer than max_duration_s (4 s) in spin");
}

TEST(EncoderDrive, OneSamplePerStampRatesOverTheWindowAndAJumpRefused) {
  EncoderDriveOptions o;
  o.max_encoder_rate_pulses_per_s = 1000;
  EncoderDrive d(o, 2.0);
  EncoderTracker::Step step;
  EXPECT_EQ(d.add(0.0, 0, 0, &step), "");
  EXPECT_TRUE(step.first);
  d.restartSamples();
  for (int k = 1; k <= 20; ++k) {
    // Each wheel's message on its own, with one stamp: the second completes the first's sample.
    EXPECT_EQ(d.add(0.05 * k, 5 * k, 10 * (k - 1), &step), "");
    d.keepSample();
    EXPECT_EQ(d.add(0.05 * k, 5 * k, 10 * k, &step), "");
    d.keepSample();
  }
  ASSERT_EQ(d.samples().size(), 21u);
  EXPECT_DOUBLE_EQ(d.samples().back().right, 200);
  EXPECT_NEAR(d.rate(0, 0.5), 100, 1e-9);
  EXPECT_NEAR(d.rate(1, 0.5), 200, 1e-9);
  d.forgetOlderThan(0.3);
  EXPECT_NEAR(d.samples().front().stamp_s, 0.7, 1e-9);
  EXPECT_NE(d.add(1.1, 5 * 20 + 200, 200, &step).find("encoder jump"), std::string::npos);
}

TEST(EncoderDrive, FollowsARateStallsAndSettles) {
  EncoderDriveOptions o;
  o.stall_s = 1.0;
  o.still_s = 0.2;
  o.settle_s = 0.3;
  EncoderDrive d(o, 2.0);
  EncoderTracker::Step step;
  d.add(0.0, 0, 0, &step);
  d.startMotion(0.0, 0.2);
  d.clock().start(0.0);
  d.follow(1, 50, 100, 0.5);  // half the rate: the duty rises by gain·dt·0.5
  EXPECT_DOUBLE_EQ(d.duty(1), 0.2 + 0.3 * 0.5 * 0.5);
  EXPECT_DOUBLE_EQ(d.duty(0), 0.2);
  EXPECT_EQ(d.stall(0, 0.9), "");
  EXPECT_NE(d.stall(0, 1.1).find("the left wheel has not moved"), std::string::npos);
  d.stop(1.0);
  d.add(1.25, 0, 0, &step);
  EXPECT_FALSE(d.settled(1.25));  // before settle_s
  d.add(1.35, 0, 0, &step);
  EXPECT_TRUE(d.settled(1.35));  // still since 0.0, settle_s passed
}

TEST(StatusThrottle, PublishesAKeyChangeAtOnceAndTheRestAtTheRate) {
  StatusThrottle t(2.0);
  EXPECT_TRUE(t.due("camera/probe", 0.0));
  EXPECT_TRUE(t.keyChanged());
  EXPECT_FALSE(t.due("camera/probe", 0.4));
  EXPECT_TRUE(t.due("camera/probe", 0.4, true));
  EXPECT_FALSE(t.keyChanged());
  EXPECT_TRUE(t.due("camera/sweep", 0.5));
  EXPECT_TRUE(t.keyChanged());
  EXPECT_TRUE(t.due("camera/sweep", 1.0));
  EXPECT_FALSE(t.keyChanged());
}

}  // namespace
}  // namespace autocal
