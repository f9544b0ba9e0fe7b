// The simulator's physics against closed-form kinematics: a calibration can only be as good as
// the simulator is true.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autocal/errors.h"
#include "autocal/sim/config.h"
#include "autocal/sim/simulation.h"

using autocal::sim::Pose2;
using autocal::sim::RobotConfig;
using autocal::sim::Side;
using autocal::sim::Simulation;
using autocal::sim::SimulationOptions;
using autocal::sim::WorldConfig;

namespace {

RobotConfig defaultRobot() {
  return autocal::sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml");
}

RobotConfig idealRobot() {
  RobotConfig r = defaultRobot();
  r.wheel_radius_left = r.wheel_radius_right = 0.0318;
  r.motor_gain_left = r.motor_gain_right = 1.0;
  return r;
}

WorldConfig emptyWorld() { return WorldConfig(); }

double distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return (a - b).norm(); }

TEST(SimPhysics, MotorModelHasDeadbandAndReachesGainTimesConstant) {
  EXPECT_EQ(autocal::sim::steadyWheelSpeed(0.05, 1.0, 27.0, 0.08), 0.0);
  EXPECT_EQ(autocal::sim::steadyWheelSpeed(-0.08, 1.0, 27.0, 0.08), 0.0);
  EXPECT_NEAR(autocal::sim::steadyWheelSpeed(1.0, 0.9, 27.0, 0.08), 0.9 * 27.0, 1e-12);
  EXPECT_NEAR(autocal::sim::steadyWheelSpeed(-1.0, 1.0, 27.0, 0.08), -27.0, 1e-12);
  EXPECT_GT(autocal::sim::steadyWheelSpeed(0.1, 1.0, 27.0, 0.08), 0.0);
}

TEST(SimPhysics, EqualWheelsDriveStraight) {
  Simulation sim(idealRobot(), emptyWorld(), SimulationOptions());
  sim.setDuty(0.5, 0.5);
  double max_lateral = 0;
  while (sim.pose().x_m < 2.0 && sim.time_s() < 30) {
    sim.step();
    max_lateral = std::max(max_lateral, std::abs(sim.pose().y_m));
  }
  ASSERT_GE(sim.pose().x_m, 2.0) << "the robot did not cover 2 m";
  EXPECT_LT(max_lateral, 1e-3);
  EXPECT_LT(std::abs(sim.pose().yaw_rad), 1e-4);
}

TEST(SimPhysics, UnequalRadiiFollowTheAnalyticArc) {
  RobotConfig r = idealRobot();
  r.wheel_radius_right = 1.02 * r.wheel_radius_left;
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.4, 0.4);
  sim.advance(0.5);  // past the motors' lag
  const Pose2 a = sim.pose();
  // Arc length of the axle centre, summed from the true positions.
  double s = 0;
  Pose2 prev = a;
  double yaw_change = 0;
  for (int i = 0; i < 6000; ++i) {
    sim.step();
    const Pose2 p = sim.pose();
    s += std::hypot(p.x_m - prev.x_m, p.y_m - prev.y_m);
    yaw_change += std::remainder(p.yaw_rad - prev.yaw_rad, 2 * M_PI);
    prev = p;
  }
  ASSERT_GT(s, 1.0);
  // Equal wheel speeds: v_i = r_i w, curvature = (v_R - v_L) / (b (v_R + v_L) / 2).
  const double expected = 2 * (r.wheel_radius_right - r.wheel_radius_left) /
                          (r.wheelbase * (r.wheel_radius_right + r.wheel_radius_left));
  const double curvature = yaw_change / s;
  EXPECT_NEAR(curvature / expected, 1.0, 0.01) << "curvature " << curvature << " expected " << expected;
  // The chord agrees with the circle of that curvature too.
  const double radius = 1 / expected;
  const double chord = std::hypot(prev.x_m - a.x_m, prev.y_m - a.y_m);
  EXPECT_NEAR(chord, 2 * radius * std::sin(0.5 * yaw_change), 0.01 * chord);
}

TEST(SimPhysics, PivotOnStoppedWheelKeepsItsContactPointStill) {
  for (Side stopped : {Side::kLeft, Side::kRight}) {
    Simulation sim(defaultRobot(), emptyWorld(), SimulationOptions());
    const Eigen::Vector2d start = sim.wheelContact(stopped);
    const Eigen::Vector2d other_start = sim.wheelContact(stopped == Side::kLeft ? Side::kRight : Side::kLeft);
    if (stopped == Side::kLeft) {
      sim.setDuty(0.0, 0.4);
    } else {
      sim.setDuty(0.4, 0.0);
    }
    double max_drift = 0, turned = 0, prev_yaw = sim.pose().yaw_rad;
    while (std::abs(turned) < 2 * M_PI && sim.time_s() < 60) {
      sim.step();
      max_drift = std::max(max_drift, distance(sim.wheelContact(stopped), start));
      turned += std::remainder(sim.pose().yaw_rad - prev_yaw, 2 * M_PI);
      prev_yaw = sim.pose().yaw_rad;
    }
    ASSERT_GE(std::abs(turned), 2 * M_PI) << "the robot did not complete a turn";
    EXPECT_LT(max_drift, 1e-3) << "stopped wheel " << static_cast<int>(stopped);
    // The moving wheel stays on the circle of radius = wheelbase around it.
    const Eigen::Vector2d other = sim.wheelContact(stopped == Side::kLeft ? Side::kRight : Side::kLeft);
    EXPECT_NEAR(distance(other, start), distance(other_start, start), 1e-3);
    // Turning direction: on the stopped left wheel, the right wheel drives the robot round
    // counter-clockwise (yaw increases); on the stopped right wheel, clockwise.
    EXPECT_EQ(turned > 0, stopped == Side::kLeft);
  }
}

TEST(SimPhysics, EncoderTicksMatchTheWheelRotationWithinOneTick) {
  const RobotConfig r = idealRobot();
  Simulation sim(r, emptyWorld(), SimulationOptions());
  const Eigen::Vector2d left0 = sim.wheelContact(Side::kLeft), right0 = sim.wheelContact(Side::kRight);
  sim.setDuty(0.6, 0.6);
  sim.advance(4.0);
  sim.setDuty(0.0, 0.0);
  sim.advance(0.5);
  // Driving straight without slip, the wheel turned by (distance rolled) / radius.
  const double per_tick = 2 * M_PI / r.encoder_resolution;
  const double left_rot = distance(sim.wheelContact(Side::kLeft), left0) / r.wheel_radius_left;
  const double right_rot = distance(sim.wheelContact(Side::kRight), right0) / r.wheel_radius_right;
  EXPECT_GT(left_rot, 20.0);
  EXPECT_NEAR(sim.encoderTicks(Side::kLeft) * per_tick, left_rot, per_tick);
  EXPECT_NEAR(sim.encoderTicks(Side::kRight) * per_tick, right_rot, per_tick);
  // Backwards, ticks count down.
  const int32_t before = sim.encoderTicks(Side::kLeft);
  sim.setDuty(-0.5, -0.5);
  sim.advance(1.0);
  EXPECT_LT(sim.encoderTicks(Side::kLeft), before - 20);
}

TEST(SimPhysics, MotorGainsScaleWheelSpeeds) {
  RobotConfig r = idealRobot();
  r.motor_gain_right = 0.9;
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.7, 0.7);
  sim.advance(1.0);
  EXPECT_NEAR(sim.wheelSpeed(Side::kRight) / sim.wheelSpeed(Side::kLeft), 0.9, 1e-6);
  // The robot turns right (towards the slower wheel): yaw decreases.
  EXPECT_LT(sim.pose().yaw_rad, -0.05);
}

// Static friction: from rest a wheel needs its breakaway duty; once turning it runs on at a duty
// between the deadband and the breakaway, at the running motor model's speed.
TEST(SimPhysics, StaticFrictionNeedsTheBreakawayDutyToStartOnlyFromRest) {
  RobotConfig r = idealRobot();
  r.deadband = 0.08;
  r.breakaway_duty_left = 0.12;
  r.breakaway_duty_right = 0.08;  // none on the right
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.10, 0.10);
  sim.advance(1.0);
  EXPECT_EQ(sim.wheelAngle(Side::kLeft), 0.0) << "the left wheel broke away below its breakaway";
  EXPECT_GT(sim.wheelAngle(Side::kRight), 0.1);
  sim.setDuty(0.13, 0.10);
  sim.advance(0.5);
  EXPECT_GT(sim.wheelSpeed(Side::kLeft), 0.0);
  sim.setDuty(0.10, 0.10);
  sim.advance(1.0);
  const double running = autocal::sim::steadyWheelSpeed(0.10, 1.0, r.motor_constant, r.deadband);
  EXPECT_NEAR(sim.wheelSpeed(Side::kLeft), running, 1e-3 * running);
  EXPECT_NEAR(sim.wheelSpeed(Side::kRight), running, 1e-3 * running);
  // Stopped, it needs the breakaway again.
  sim.setDuty(0.0, 0.0);
  sim.advance(1.0);
  ASSERT_EQ(sim.wheelSpeed(Side::kLeft), 0.0);
  const double at_rest = sim.wheelAngle(Side::kLeft);
  sim.setDuty(-0.11, 0.0);
  sim.advance(1.0);
  EXPECT_EQ(sim.wheelAngle(Side::kLeft), at_rest);
}

TEST(SimPhysics, BackwardGainRatioScalesOnlyBackwardDuties) {
  RobotConfig r = idealRobot();
  r.backward_gain_ratio_left = 0.9;
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.5, 0.5);
  sim.advance(1.0);
  EXPECT_NEAR(sim.wheelSpeed(Side::kLeft) / sim.wheelSpeed(Side::kRight), 1.0, 1e-6);
  sim.setDuty(-0.5, -0.5);
  sim.advance(1.0);
  EXPECT_NEAR(sim.wheelSpeed(Side::kLeft) / sim.wheelSpeed(Side::kRight), 0.9, 1e-6);
}

TEST(SimPhysics, GainDriftsLinearlyWithSimulatedTime) {
  RobotConfig r = idealRobot();
  r.gain_drift_per_min = -0.03;  // a battery sagging 3 % a minute
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.5, 0.5);
  sim.advance(1.0);
  const double early = sim.wheelSpeed(Side::kLeft), early_t = sim.time_s();
  sim.advance(29.0);
  const double expected = (1 - 0.03 * sim.time_s() / 60) / (1 - 0.03 * early_t / 60);
  EXPECT_NEAR(sim.wheelSpeed(Side::kLeft) / early, expected, 1e-3);
}

// After a reversal the motor crosses the gearbox's play before the wheel follows: the wheel stands
// until the same motor without play would have turned it back by the play, and then the robot
// follows the wheel without a jerk (no slip).
TEST(SimPhysics, BacklashHoldsTheWheelWhileTheMotorCrossesThePlay) {
  RobotConfig ideal = idealRobot(), play = idealRobot();
  play.backlash_rad = 0.06;
  Simulation a(ideal, emptyWorld(), SimulationOptions()), b(play, emptyWorld(), SimulationOptions());
  auto both = [&](double duty, double s) {
    a.setDuty(duty, duty);
    b.setDuty(duty, duty);
    a.advance(s);
    b.advance(s);
  };
  both(0.4, 1.0);
  both(0.0, 0.5);
  ASSERT_EQ(a.wheelSpeed(Side::kLeft), 0.0);
  ASSERT_EQ(b.wheelSpeed(Side::kLeft), 0.0);
  const double a0 = a.wheelAngle(Side::kLeft), b0 = b.wheelAngle(Side::kLeft), xb = b.pose().x_m;
  a.setDuty(-0.4, -0.4);
  b.setDuty(-0.4, -0.4);
  int held_steps = 0, ideal_steps = 0;
  while (a0 - a.wheelAngle(Side::kLeft) < play.backlash_rad) {
    a.step();
    b.step();
    ++ideal_steps;
    if (b.wheelAngle(Side::kLeft) == b0) ++held_steps;
  }
  EXPECT_EQ(held_steps, ideal_steps) << "the wheel moved before the motor crossed the play";
  b.advance(0.02);
  EXPECT_LT(b.wheelAngle(Side::kLeft), b0) << "the wheel did not follow once the play was crossed";
  b.advance(1.0);
  b.setDuty(0.0, 0.0);
  b.advance(0.5);
  // The body comes back by the wheels' arc: no slip where the gear took up the play.
  const double rim_m = play.wheel_radius_left * (b0 - b.wheelAngle(Side::kLeft));
  EXPECT_NEAR(xb - b.pose().x_m, rim_m, 2e-4);
  EXPECT_NEAR(b.wheelAngle(Side::kRight), b.wheelAngle(Side::kLeft), 1e-9);
  // The encoder counts the wheel, not the motor.
  EXPECT_NEAR(b.encoderTicks(Side::kLeft),
              std::floor(b.wheelAngle(Side::kLeft) / (2 * M_PI) * play.encoder_resolution), 1.0);
}

// Each wheel's contact point moves by (1 - slip) of its rim's speed, slip redrawn at intervals from
// N(0, sigma) with the simulation's seed: the distance driven scatters about the encoders' with
// that spread, the heading wanders, and a seed repeats its run.
TEST(SimPhysics, WheelSlipScattersTheDistanceAboutTheEncodersAndRepeatsWithItsSeed) {
  RobotConfig r = idealRobot();
  r.wheel_slip_sigma = 0.02;
  r.wheel_slip_interval_s = 0.2;
  SimulationOptions o;
  o.seed = 7;
  Simulation sim(r, emptyWorld(), o), again(r, emptyWorld(), o);
  o.seed = 8;
  Simulation other(r, emptyWorld(), o);
  for (Simulation* s : {&sim, &again, &other}) s->setDuty(0.4, 0.4);
  sim.advance(1.0);
  again.advance(1.0);
  other.advance(1.0);
  std::vector<double> ratio;  // ground distance / rim distance per slip interval, the robot at speed
  for (int k = 0; k < 100; ++k) {
    const Pose2 p0 = sim.pose();
    const double rim0 = r.wheel_radius_left * (sim.wheelAngle(Side::kLeft) + sim.wheelAngle(Side::kRight)) / 2;
    sim.advance(0.2);
    again.advance(0.2);
    other.advance(0.2);
    const double rim = r.wheel_radius_left * (sim.wheelAngle(Side::kLeft) + sim.wheelAngle(Side::kRight)) / 2 - rim0;
    ratio.push_back(std::hypot(sim.pose().x_m - p0.x_m, sim.pose().y_m - p0.y_m) / rim);
  }
  double mean = 0, var = 0;
  for (double q : ratio) mean += q / ratio.size();
  for (double q : ratio) var += (q - mean) * (q - mean) / (ratio.size() - 1);
  // The mean of two wheels' slips: sigma / sqrt(2) (the body's lag behind each redraw smooths it a
  // little).
  EXPECT_NEAR(mean, 1.0, 0.01);
  EXPECT_GT(std::sqrt(var), 0.4 * r.wheel_slip_sigma / std::sqrt(2.0));
  EXPECT_LT(std::sqrt(var), 1.3 * r.wheel_slip_sigma / std::sqrt(2.0));
  EXPECT_GT(std::abs(sim.pose().yaw_rad), 1e-3) << "unequal slips should turn the robot";
  EXPECT_EQ(sim.pose().x_m, again.pose().x_m);
  EXPECT_EQ(sim.pose().yaw_rad, again.pose().yaw_rad);
  EXPECT_NE(sim.pose().yaw_rad, other.pose().yaw_rad);
  // The encoders count the wheels' rotation, slip or not.
  EXPECT_EQ(sim.wheelAngle(Side::kLeft), other.wheelAngle(Side::kLeft));
}

TEST(SimPhysics, WheelsFollowTheMotorTimeConstant) {
  const RobotConfig r = idealRobot();
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(1.0, 1.0);
  sim.advance(r.motor_time_constant);
  EXPECT_NEAR(sim.wheelSpeed(Side::kLeft) / r.motor_constant, 1 - std::exp(-1.0), 0.01);
}

// Left without drive, the wheel's first-order lag alone would creep ever slower for ever; it is
// held once the rest of its coast is a twentieth of an encoder tick or less.
TEST(SimPhysics, CoastingWheelStopsWithinATwentiethOfATickOfTheLagsCoast) {
  const RobotConfig r = idealRobot();
  Simulation sim(r, emptyWorld(), SimulationOptions());
  sim.setDuty(0.5, 0.5);
  sim.advance(1.0);
  const double w0 = sim.wheelSpeed(Side::kLeft), a0 = sim.wheelAngle(Side::kLeft);
  ASSERT_GT(w0, 10.0);
  sim.setDuty(0.0, 0.0);
  sim.advance(0.6);
  EXPECT_EQ(sim.wheelSpeed(Side::kLeft), 0.0);
  EXPECT_EQ(sim.wheelSpeed(Side::kRight), 0.0);
  // The lag's whole coast, integrated as the simulation integrates it (step by step, exactly).
  const double dt = sim.timestep_s(), decay = std::exp(-dt / r.motor_time_constant);
  const double lag_coast = w0 * dt * decay / (1.0 - decay);
  const double coast = sim.wheelAngle(Side::kLeft) - a0;
  const double tick = 2 * M_PI / r.encoder_resolution;
  EXPECT_LE(coast, lag_coast);
  EXPECT_GT(coast, lag_coast - tick / 20.0);
  // Once held, the wheel and the robot stay where they are.
  const Pose2 held = sim.pose();
  const double held_angle = sim.wheelAngle(Side::kLeft);
  sim.advance(0.5);
  EXPECT_EQ(sim.wheelAngle(Side::kLeft), held_angle);
  EXPECT_NEAR(sim.pose().x_m, held.x_m, 1e-6);
}

TEST(SimPhysics, WallStopsTheRobot) {
  WorldConfig w;
  autocal::sim::WallConfig wall;
  wall.x0_m = 0.5;
  wall.y0_m = -1;
  wall.x1_m = 0.5;
  wall.y1_m = 1;
  w.walls.push_back(wall);
  Simulation sim(idealRobot(), w, SimulationOptions());
  sim.setDuty(0.6, 0.6);
  sim.advance(5.0);
  // Chassis front = axle + offset + length / 2; the wall's face is at 0.5 - thickness / 2.
  const RobotConfig r = idealRobot();
  const double front = sim.pose().x_m + r.chassis_offset_x_m + 0.5 * r.chassis_length_m;
  EXPECT_LT(front, 0.5 - 0.5 * wall.thickness_m + 0.012);
  EXPECT_GT(front, 0.5 - 0.5 * wall.thickness_m - 0.03);
  EXPECT_TRUE(sim.inContact());
  // The wheels keep turning (slipping) while the robot is held.
  EXPECT_GT(sim.wheelSpeed(Side::kLeft), 10.0);
}

TEST(SimPhysics, SameCommandsGiveIdenticalRuns) {
  auto run = [] {
    Simulation sim(defaultRobot(), autocal::sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) +
                                                                 "/sim/config/world.yaml"),
                   SimulationOptions());
    std::vector<double> trace;
    for (int k = 0; k < 40; ++k) {
      sim.setDuty(0.3 + 0.01 * k, (k % 3) * 0.25 - 0.2);
      sim.advance(0.1);
      trace.push_back(sim.pose().x_m);
      trace.push_back(sim.pose().y_m);
      trace.push_back(sim.pose().yaw_rad);
      trace.push_back(sim.encoderTicks(Side::kLeft));
      trace.push_back(sim.encoderTicks(Side::kRight));
    }
    return trace;
  };
  const auto a = run(), b = run();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "at " << i;
}

TEST(SimPhysics, NonFiniteDutyIsRefusedAndLargeDutyClamped) {
  Simulation sim(idealRobot(), emptyWorld(), SimulationOptions());
  EXPECT_THROW(sim.setDuty(std::nan(""), 0.0), autocal::InputError);
  EXPECT_THROW(sim.setDuty(0.0, INFINITY), autocal::InputError);
  sim.setDuty(3.0, -2.0);
  EXPECT_EQ(sim.duty(Side::kLeft), 1.0);
  EXPECT_EQ(sim.duty(Side::kRight), -1.0);
}

}  // namespace
