// One wheel at a time (paper 000 §3.2): the wheel command of a turn, and the minimum moving duty
// probe against a scripted motor — a deadband per wheel and direction, speed linear above it (as
// the simulator's motor, sim/config/robot_ideal.yaml), encoders quantised.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "autocal/camera/min_duty_probe.h"
#include "autocal/camera/wheel_turn.h"
#include "autocal/errors.h"

using namespace autocal::camera;

namespace {

struct Motor {
  double deadband = 0.08;
  double gain = 1.0;           ///< 0 = dead wheel
  int wiring = 1;              ///< -1 = the encoder counts the other way
  double rad_per_duty_s = 27;  ///< wheel speed per duty above the deadband [rad/s]
  double ticks_per_rad = 135 / (2 * M_PI);
  double phase_ticks = 0.37;  ///< where the wheel rests between two ticks

  int ticks(double duty, double pulse_s) const {
    const double over = std::max(0.0, std::abs(duty) - deadband);
    const double angle = gain * rad_per_duty_s * over * pulse_s;
    const double moved = std::floor(phase_ticks + angle * ticks_per_rad) - std::floor(phase_ticks);
    return wiring * (duty >= 0 ? 1 : -1) * static_cast<int>(moved);
  }
  /// The least duty whose pulse moves min_ticks (from the model, not from the probe).
  double threshold(int min_ticks, double pulse_s) const {
    const double angle = (min_ticks - phase_ticks + std::floor(phase_ticks)) / ticks_per_rad;
    return deadband + angle / (gain * rad_per_duty_s * pulse_s);
  }
};

/// Runs the probe; motors indexed left+, left-, right+, right-.
MinDutyProbe runProbe(const MinDutyProbeOptions& o, const Motor (&m)[4]) {
  MinDutyProbe p(o);
  int guard = 0;
  while (!p.finished() && ++guard < 1000) {
    const WheelCommand c = p.command();
    const int k = (c.wheel == Wheel::kLeft ? 0 : 2) + (c.sign > 0 ? 0 : 1);
    const WheelDuties d = p.pulse();
    const double duty = c.wheel == Wheel::kLeft ? d.left : d.right;
    EXPECT_EQ(c.wheel == Wheel::kLeft ? d.right : d.left, 0.0);  // one wheel at a time
    EXPECT_EQ(duty > 0 ? 1 : -1, c.sign);
    p.report(m[k].ticks(duty, o.pulse_s));
  }
  return p;
}

TEST(MinDutyProbe, FindsEachDeadbandWithinOneDutyStep) {
  MinDutyProbeOptions o;
  Motor m[4];
  m[0].deadband = 0.08;
  m[1].deadband = 0.11;
  m[2].deadband = 0.05;
  m[2].gain = 0.97;
  m[3].deadband = 0.15;
  m[3].phase_ticks = 0.9;
  const MinDutyProbe p = runProbe(o, m);
  ASSERT_FALSE(p.failed()) << p.failure();
  const double found[4] = {p.result().left_forward, p.result().left_backward,
                           p.result().right_forward, p.result().right_backward};
  for (int k = 0; k < 4; ++k) {
    const double t = m[k].threshold(o.min_ticks, o.pulse_s);
    EXPECT_GE(found[k], t - 1e-9) << "motor " << k;
    EXPECT_LT(found[k], t + o.duty_step) << "motor " << k;
  }
  EXPECT_EQ(p.result().forWheel(Wheel::kRight, -1), p.result().right_backward);
  EXPECT_EQ(p.result().forCommand({Wheel::kLeft, 1}), p.result().left_forward);
}

TEST(MinDutyProbe, DeadWheelFails) {
  MinDutyProbeOptions o;
  Motor m[4];
  m[2].gain = 0;  // right wheel: no motion at any duty
  m[3].gain = 0;
  const MinDutyProbe p = runProbe(o, m);
  ASSERT_TRUE(p.failed());
  EXPECT_EQ(p.failure(),
            "right wheel did not move forward up to duty 0.40: encoder or motor fault");
  EXPECT_GT(p.result().left_backward, 0);  // the left wheel was measured before
}

TEST(MinDutyProbe, ReversedEncoderFails) {
  MinDutyProbeOptions o;
  Motor m[4];
  m[0].wiring = m[1].wiring = -1;
  const MinDutyProbe p = runProbe(o, m);
  ASSERT_TRUE(p.failed());
  EXPECT_NE(p.failure().find("left wheel turned backward at forward duty"), std::string::npos)
      << p.failure();
}

TEST(MinDutyProbe, ImageMotionCountsWhenTheEncoderIsSilent) {
  MinDutyProbeOptions o;
  MinDutyProbe p(o);
  for (int i = 0; i < 5; ++i) p.report(0, false);
  const double duty = p.duty();
  EXPECT_NEAR(duty, o.start_duty + 5 * o.duty_step, 1e-12);
  p.report(0, true);
  EXPECT_EQ(p.result().left_forward, duty);
  o.use_image_motion = false;
  MinDutyProbe q(o);
  q.report(0, true);
  EXPECT_EQ(q.result().left_forward, 0);
  EXPECT_GT(q.duty(), o.start_duty);
}

TEST(MinDutyProbe, ValidateNamesTheBadKey) {
  MinDutyProbeOptions o;
  o.max_duty = 0.01;
  EXPECT_THROW(
      {
        try {
          MinDutyProbe p(o);
        } catch (const autocal::ConfigError& e) {
          EXPECT_EQ(std::string(e.what()).rfind("max_duty:", 0), 0u) << e.what();
          throw;
        }
      },
      autocal::ConfigError);
  o = MinDutyProbeOptions{};
  o.min_ticks = 0;
  EXPECT_THROW(o.validate(), autocal::ConfigError);
  o = MinDutyProbeOptions{};
  o.duty_step = 0;
  EXPECT_THROW(o.validate(), autocal::ConfigError);
}

// --- one wheel at a time ----------------------------------------------------------------------

TEST(WheelTurn, EveryConventionTurnsTheRightWayOnOneWheel) {
  for (PivotConvention p : {PivotConvention::kPivotLeft, PivotConvention::kPivotRight,
                            PivotConvention::kDriveForward, PivotConvention::kDriveBackward}) {
    for (TurnDirection d : {TurnDirection::kCcw, TurnDirection::kCw}) {
      const WheelDuties w = toDuties(turnCommand(d, p), 0.15);
      // Exactly one wheel driven; yaw rate ∝ right − left speed.
      EXPECT_TRUE((w.left == 0) != (w.right == 0)) << name(p) << " " << name(d);
      EXPECT_EQ(w.right - w.left > 0 ? 1 : -1, sign(d)) << name(p) << " " << name(d);
      EXPECT_NEAR(std::abs(w.left + w.right), 0.15, 1e-12);
    }
    EXPECT_EQ(parsePivotConvention(name(p)), p);
  }
  EXPECT_EQ(toDuties(turnCommand(TurnDirection::kCcw, PivotConvention::kPivotLeft), 1).left, 0);
  EXPECT_EQ(toDuties(turnCommand(TurnDirection::kCw, PivotConvention::kPivotLeft), 1).left, 0);
  EXPECT_EQ(toDuties(turnCommand(TurnDirection::kCcw, PivotConvention::kPivotRight), 1).right, 0);
  EXPECT_EQ(turnCommand(TurnDirection::kCw, PivotConvention::kDriveForward).wheel, Wheel::kLeft);
  EXPECT_EQ(turnCommand(TurnDirection::kCcw, PivotConvention::kDriveBackward).wheel, Wheel::kLeft);
  EXPECT_THROW(parsePivotConvention("left"), autocal::ConfigError);
}

}  // namespace
