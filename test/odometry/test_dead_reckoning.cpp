// Dead reckoning: closed-form kinematics of straight runs, spins and arcs, and the integrators.
#include <gtest/gtest.h>

#include <cmath>

#include "autocal/errors.h"
#include "autocal/odometry/dead_reckoning.h"

using namespace autocal::odometry;

namespace {

DiffDriveParams duckiebot() { return DiffDriveParams::fromWheel(0.066, 135.0, 0.102); }

TEST(DeadReckoning, StraightRunMovesAlongHeading) {
  const DiffDriveParams p = duckiebot();
  DeadReckoning dr(p);
  dr.addPulses(1000, 1000);
  EXPECT_NEAR(dr.pose().x_m, 1000 * p.left_m_per_pulse, 1e-12);
  EXPECT_NEAR(dr.pose().y_m, 0.0, 1e-12);
  EXPECT_NEAR(dr.pose().yaw_rad, 0.0, 1e-12);
  EXPECT_NEAR(dr.distance_m(), 1000 * p.left_m_per_pulse, 1e-12);
}

TEST(DeadReckoning, SpinInPlaceTurnsWithoutMoving) {
  const DiffDriveParams p = duckiebot();
  DeadReckoning dr(p);
  dr.addPulses(-100, 100);
  EXPECT_NEAR(dr.pose().yaw_rad, 200 * p.left_m_per_pulse / p.wheelbase_m, 1e-12);
  EXPECT_NEAR(dr.pose().x_m, 0.0, 1e-12);
  EXPECT_NEAR(dr.pose().y_m, 0.0, 1e-12);
}

TEST(DeadReckoning, ExactArcMatchesTheCircleInOneStep) {
  const DiffDriveParams p = duckiebot();
  const double nl = 300, nr = 500;
  const double dl = nl * p.left_m_per_pulse, dr_m = nr * p.right_m_per_pulse;
  const double R = 0.5 * p.wheelbase_m * (dr_m + dl) / (dr_m - dl);
  const double th = (dr_m - dl) / p.wheelbase_m;
  DeadReckoning dr(p, Integrator::kExact);
  dr.addPulses(nl, nr);
  EXPECT_NEAR(dr.pose().x_m, R * std::sin(th), 1e-12);
  EXPECT_NEAR(dr.pose().y_m, R * (1 - std::cos(th)), 1e-12);
  EXPECT_NEAR(dr.pose().yaw_rad, th, 1e-12);
}

TEST(DeadReckoning, ExactIsIndependentOfStepSizeAndOthersConvergeToIt) {
  const DiffDriveParams p = duckiebot();
  DeadReckoning one(p, Integrator::kExact);
  one.addPulses(400, 700);
  DeadReckoning many(p, Integrator::kExact);
  for (int i = 0; i < 1000; ++i) many.addPulses(0.4, 0.7);
  EXPECT_NEAR(one.pose().x_m, many.pose().x_m, 1e-12);
  EXPECT_NEAR(one.pose().y_m, many.pose().y_m, 1e-12);

  auto err = [&](Integrator in, int steps) {
    DeadReckoning d(p, in);
    for (int i = 0; i < steps; ++i) d.addPulses(400.0 / steps, 700.0 / steps);
    return std::hypot(d.pose().x_m - one.pose().x_m, d.pose().y_m - one.pose().y_m);
  };
  // Euler is first order, the mid-point rule second order.
  EXPECT_GT(err(Integrator::kEuler, 10), 1e-3);
  EXPECT_LT(err(Integrator::kEuler, 1000), err(Integrator::kEuler, 10) / 50);
  EXPECT_LT(err(Integrator::kRungeKutta2, 10), err(Integrator::kEuler, 10) / 10);
  EXPECT_LT(err(Integrator::kRungeKutta2, 100), err(Integrator::kEuler, 100) / 10);
}

TEST(DeadReckoning, TinyTurnsDoNotDivideByZero) {
  const DiffDriveParams p = duckiebot();
  DeadReckoning dr(p);
  dr.addPulses(1000, 1000 + 1e-9);
  EXPECT_TRUE(std::isfinite(dr.pose().x_m));
  EXPECT_NEAR(dr.pose().x_m, 1000 * p.left_m_per_pulse, 1e-9);
}

TEST(DeadReckoning, TicksAreDifferencedAcrossWrapAround) {
  const DiffDriveParams p = duckiebot();
  DeadReckoning dr(p);
  dr.addTicks(2147483600, 2147483600);    // reference only
  dr.addTicks(-2147483646, -2147483646);  // +50 ticks through the wrap
  EXPECT_NEAR(dr.pose().x_m, 50 * p.left_m_per_pulse, 1e-12);
}

TEST(DeadReckoning, UmbmarkCorrectionKeepsMeanAndSetsRatio) {
  const DiffDriveParams p = duckiebot();
  const DiffDriveParams c = applyUmbmarkCorrection(p, 1.01, 1.05);
  EXPECT_NEAR(c.right_m_per_pulse / c.left_m_per_pulse, 1.01, 1e-12);
  EXPECT_NEAR(0.5 * (c.right_m_per_pulse + c.left_m_per_pulse), p.left_m_per_pulse, 1e-15);
  EXPECT_NEAR(c.wheelbase_m, 1.05 * p.wheelbase_m, 1e-15);
  EXPECT_THROW(applyUmbmarkCorrection(p, 0.0, 1.0), autocal::CalibrationError);
}

TEST(DeadReckoning, RejectsBadParametersAndNames) {
  DiffDriveParams p = duckiebot();
  p.wheelbase_m = 0.0;
  EXPECT_THROW(DeadReckoning{p}, autocal::ConfigError);
  EXPECT_THROW(integratorFromName("rk4"), autocal::ConfigError);
  EXPECT_EQ(integratorFromName("exact"), Integrator::kExact);
  EXPECT_NEAR(wrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(-M_PI / 2), -M_PI / 2, 1e-12);
}

}  // namespace
