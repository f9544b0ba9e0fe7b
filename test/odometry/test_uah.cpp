// The UAH method (paper 002) on synthetic signals from a known robot in a known scene of walls:
// range readings while pivoting and spinning (noise, dropouts, quantised pulses, uneven turn
// rate), straight runs with heading wobble. Every random source is seeded.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "autocal/errors.h"
#include "autocal/odometry/uah.h"

using namespace autocal::odometry;

namespace {

struct Vec {
  double x, y;
};
struct Segment {
  Vec a, b;
};

// A scene of walls; range(origin, direction) is the nearest hit along the ray.
struct Scene {
  std::vector<Segment> walls;
  void addPolygon(const std::vector<Vec>& p) {
    for (size_t i = 0; i < p.size(); ++i) walls.push_back({p[i], p[(i + 1) % p.size()]});
  }
  double range(Vec o, double dir) const {
    const Vec d{std::cos(dir), std::sin(dir)};
    double best = INFINITY;
    for (const auto& w : walls) {
      const Vec e{w.b.x - w.a.x, w.b.y - w.a.y};
      const double den = d.x * e.y - d.y * e.x;
      if (std::abs(den) < 1e-12) continue;
      const Vec ao{w.a.x - o.x, w.a.y - o.y};
      const double t = (ao.x * e.y - ao.y * e.x) / den;
      const double u = (ao.x * d.y - ao.y * d.x) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    return best;
  }
};

Scene irregularRoom() {
  Scene s;
  s.addPolygon({{-0.6, -0.5}, {1.3, -0.7}, {1.1, 0.9}, {0.2, 1.2}, {-0.8, 0.6}});
  s.addPolygon({{0.45, 0.35}, {0.7, 0.4}, {0.65, 0.6}, {0.42, 0.55}});  // a box
  s.addPolygon({{-0.45, -0.2}, {-0.35, -0.25}, {-0.3, -0.1}});          // a bin
  return s;
}

Scene squareRoom(Vec centre) {
  Scene s;
  s.addPolygon({{centre.x - 1, centre.y - 1},
                {centre.x + 1, centre.y - 1},
                {centre.x + 1, centre.y + 1},
                {centre.x - 1, centre.y + 1}});
  return s;
}

const Vec kPivotWorld{0.05, -0.1};  // where turnSignal's centre of rotation stands

struct Robot {
  double left_m_per_pulse = 0, right_m_per_pulse = 0;  // true distance per pulse [m]
  double b = 0;             // true effective wheelbase [m]
  double b_pivot = 0;       // pivot-to-moving-wheel distance with the pivot piece [m]
  Vec sensor{0.08, 0.02};   // range sensor in the robot frame, looking forward
};

Robot knownRobot() {
  const DiffDriveParams nominal = DiffDriveParams::fromWheel(0.066, 135, 0.102);
  Robot r;
  r.left_m_per_pulse = nominal.left_m_per_pulse * 0.999;
  r.right_m_per_pulse = nominal.right_m_per_pulse * 1.004;
  r.b = 0.104;
  r.b_pivot = 0.104 * 1.03;
  return r;
}

enum class Turn { kPivotLeftStopped, kPivotRightStopped, kSpin };

struct SignalOptions {
  double rounds = 5;
  double noise_m = 0.01;
  double dropout = 0.05;
  double max_range_m = 2.0;
  double rate_hz = 50;
  double round_time_s = 12;
  unsigned seed = 1;
};

// Range readings against the moving wheel's (quantised) pulse count while the robot turns.
std::vector<RangeSample> turnSignal(const Robot& r, const Scene& scene, Turn turn,
                                    const SignalOptions& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> noise(0.0, o.noise_m);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double theta0 = 2 * M_PI * uni(rng);
  // Centre of rotation in the robot frame and pulses of the counted wheel per radian.
  Vec icr{0, 0};
  double pulses_per_rad = 0, sign = 1;
  switch (turn) {
    case Turn::kPivotLeftStopped:      // right wheel moves forward, robot turns left about a
      icr = {0, r.b_pivot - r.b / 2};  // point b_pivot from the right wheel
      pulses_per_rad = r.b_pivot / r.right_m_per_pulse;
      break;
    case Turn::kPivotRightStopped:  // left wheel moves forward, robot turns right
      icr = {0, -(r.b_pivot - r.b / 2)};
      pulses_per_rad = r.b_pivot / r.left_m_per_pulse;
      sign = -1;
      break;
    case Turn::kSpin:  // both wheels at the same pulse rate, opposite; right one counted
      icr = {0, 0.5 * r.b * (r.right_m_per_pulse - r.left_m_per_pulse) / (r.right_m_per_pulse + r.left_m_per_pulse)};
      pulses_per_rad = r.b / (r.right_m_per_pulse + r.left_m_per_pulse);
      break;
  }
  const Vec pivot_world = kPivotWorld;
  std::vector<RangeSample> out;
  const double total = o.rounds * 2 * M_PI;
  double angle = 0, t = 0;
  const double phase = 2 * M_PI * uni(rng);
  while (angle < total) {
    // An uneven turn rate (motor ripple): readings are not uniform in pulses.
    const double omega = 2 * M_PI / o.round_time_s * (1 + 0.15 * std::sin(3.1 * t + phase));
    angle += omega / o.rate_hz;
    t += 1 / o.rate_hz;
    const double th = theta0 + sign * angle;
    const double c = std::cos(th), s = std::sin(th);
    // World position of the robot origin: the ICR stays fixed at pivot_world.
    const Vec origin{pivot_world.x - (c * icr.x - s * icr.y),
                     pivot_world.y - (s * icr.x + c * icr.y)};
    const Vec sensor{origin.x + c * r.sensor.x - s * r.sensor.y,
                     origin.y + s * r.sensor.x + c * r.sensor.y};
    double range = scene.range(sensor, th) + noise(rng);
    if (range > o.max_range_m || uni(rng) < o.dropout) range = NAN;
    out.push_back({std::floor(angle * pulses_per_rad), range});
  }
  return out;
}

RoundDetectionOptions detectionOptions(double expected) {
  RoundDetectionOptions o;
  o.expected_pulses_per_round = expected;
  o.max_range_m = 2.0;
  return o;
}

// Theoretical pulses per round from the NOMINAL robot (what the caller knows).
const DiffDriveParams kNominal = DiffDriveParams::fromWheel(0.066, 135, 0.102);
const double kPivotExpected = 2 * M_PI * kNominal.wheelbase_m / kNominal.right_m_per_pulse;
const double kSpinExpected = M_PI * kNominal.wheelbase_m / kNominal.right_m_per_pulse;

TEST(UahRoundDetection, FindsPulsesPerRoundWithinOnePulse) {
  const Robot r = knownRobot();
  const Scene scene = irregularRoom();
  const double truths[] = {2 * M_PI * r.b_pivot / r.right_m_per_pulse, 2 * M_PI * r.b_pivot / r.left_m_per_pulse,
                           2 * M_PI * r.b / (r.right_m_per_pulse + r.left_m_per_pulse)};
  const Turn turns[] = {Turn::kPivotLeftStopped, Turn::kPivotRightStopped, Turn::kSpin};
  double worst = 0, worst_single = 0;
  for (int i = 0; i < 3; ++i) {
    for (unsigned seed = 1; seed <= 5; ++seed) {
      SignalOptions so;
      so.seed = seed;
      const auto det = detectWholeRound(turnSignal(r, scene, turns[i], so),
                                        detectionOptions(i == 2 ? kSpinExpected : kPivotExpected));
      worst = std::max(worst, std::abs(det.pulses_per_round - truths[i]));
      worst_single = std::max(worst_single, std::abs(det.single_round_pulses - truths[i]));
      EXPECT_NEAR(det.pulses_per_round, truths[i], 1.0) << "turn " << i << " seed " << seed;
      EXPECT_GE(det.rounds_used, 3);
    }
  }
  std::printf("[ figures  ] pulses/round worst error: %.3f pulses (first peak alone %.3f)\n", worst,
              worst_single);
}

TEST(UahRoundDetection, HeavierNoiseAndDropouts) {
  // 3 cm noise, 20 % dropouts, 3 rounds only: still within one pulse.
  const Robot r = knownRobot();
  SignalOptions so;
  so.noise_m = 0.03;
  so.dropout = 0.2;
  so.rounds = 3;
  double worst = 0;
  for (unsigned seed = 11; seed <= 15; ++seed) {
    so.seed = seed;
    const auto det = detectWholeRound(turnSignal(r, irregularRoom(), Turn::kPivotLeftStopped, so),
                                      detectionOptions(kPivotExpected));
    worst = std::max(worst, std::abs(det.pulses_per_round - 2 * M_PI * r.b_pivot / r.right_m_per_pulse));
  }
  std::printf("[ figures  ] 3 cm noise, 20 %% dropouts, 3 rounds: worst %.3f pulses\n", worst);
  EXPECT_LT(worst, 1.0);
}

TEST(UahRoundDetection, RefusesASymmetricScene) {
  const Robot r = knownRobot();
  SignalOptions so;
  so.noise_m = 0.002;
  // The square room centred on the spin: the view repeats every quarter round.
  Robot centred = r;
  centred.sensor = {0.0, 0.0};
  const auto samples = turnSignal(centred, squareRoom(kPivotWorld), Turn::kSpin, so);
  try {
    const auto d = detectWholeRound(samples, detectionOptions(kSpinExpected));
    FAIL() << "a symmetric scene was accepted: " << d.pulses_per_round << " peak "
           << d.peak_correlation << " secondary " << d.secondary_correlation << " at "
           << d.secondary_lag_pulses << " valid " << d.valid_fraction;
  } catch (const autocal::CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("symmetric or periodic"), std::string::npos) << e.what();
  }
}

TEST(UahRoundDetection, ASquareRoomOffCentreIsStillResolved) {
  // The same room with the robot 0.11 m off its centre breaks the symmetry enough.
  const Robot r = knownRobot();
  SignalOptions so;
  const auto det = detectWholeRound(turnSignal(r, squareRoom({0, 0}), Turn::kSpin, so),
                                    detectionOptions(kSpinExpected));
  EXPECT_NEAR(det.pulses_per_round, 2 * M_PI * r.b / (r.right_m_per_pulse + r.left_m_per_pulse), 1.0);
  EXPECT_LT(det.secondary_correlation, 0.8 * det.peak_correlation);
}

TEST(UahRoundDetection, RefusesAFeaturelessOrNoisyScene) {
  // A round room centred on the sensor: the range does not change with heading.
  std::vector<RangeSample> flat;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.0005);
  for (int p = 0; p < 2000; ++p)
    flat.push_back({double(p), 1.0 + 0.3 * std::sin(p * 1e-4) + noise(rng)});
  EXPECT_THROW(detectWholeRound(flat, detectionOptions(420)), autocal::CalibrationError);
  // Pure noise: no structure repeats, the peak is weak.
  std::vector<RangeSample> random;
  std::uniform_real_distribution<double> uni(0.2, 2.0);
  for (int p = 0; p < 2500; ++p) random.push_back({double(p), uni(rng)});
  try {
    detectWholeRound(random, detectionOptions(420));
    FAIL() << "noise was accepted";
  } catch (const autocal::CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("weak"), std::string::npos) << e.what();
  }
  // Too short: less than one and a half rounds.
  SignalOptions so;
  so.rounds = 1.2;
  EXPECT_THROW(detectWholeRound(turnSignal(knownRobot(), irregularRoom(), Turn::kSpin, so),
                                detectionOptions(kSpinExpected)),
               autocal::CalibrationError);
}

TEST(UahRoundDetection, ResamplingBridgesShortGapsOnly) {
  RoundDetectionOptions o = detectionOptions(100);
  o.max_gap_pulses = 3;
  std::vector<RangeSample> s{{0, 1.0}, {0.2, 1.2}, {2, 2.0}, {10, 1.0}, {11, NAN}, {12, 5.0}};
  double first = 0;
  const auto x = resampleOnPulses(s, o, &first);
  ASSERT_EQ(x.size(), 13u);
  EXPECT_NEAR(x[0], 1.1, 1e-12);   // two readings in one cell are averaged
  EXPECT_NEAR(x[1], 1.55, 1e-12);  // bridged
  EXPECT_TRUE(std::isnan(x[5]));   // gap of 8 pulses is left missing
  EXPECT_NEAR(x[10], 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(x[11]));  // a dropout at the end: nothing to bridge to (5.0 is beyond
  EXPECT_TRUE(std::isnan(x[12]));  // max_range_m)
}

TEST(UahEd, RatioOfPivotPulsesAndItsChecks) {
  const EdEstimate e = estimateEd({400, 401, 400.5}, {402, 402.5, 401.5});
  EXPECT_NEAR(e.Ed, 402.0 / 400.5, 1e-12);
  EXPECT_THROW(estimateEd({}, {400}), autocal::InputError);
  EXPECT_THROW(estimateEd({400, -1}, {400}), autocal::InputError);
  EXPECT_THROW(estimateEd({400, 420}, {400}), autocal::CalibrationError);  // 5 % spread
}

// A straight run of the known robot whose heading follows heading(s) at s metres along it; the
// measured length is the start-to-end distance (±1 mm tape), pulses are counted as integers.
template <typename Heading>
StraightRun straightRunWith(const Robot& r, double length_m, Heading heading, unsigned seed,
                            std::vector<std::pair<double, double>>* pulses_out) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> tape(0, 0.001);
  const double ds = 0.001;
  double x = 0, y = 0, sl = 0, sr = 0, s = 0, worst = 0, th = heading(0.0);
  pulses_out->clear();
  pulses_out->push_back({0, 0});
  while (x < length_m) {
    const double next = heading(s + ds);
    const double kappa = (next - th) / ds;
    x += ds * std::cos(th);
    y += ds * std::sin(th);
    sl += ds * (1 - kappa * r.b / 2);
    sr += ds * (1 + kappa * r.b / 2);
    s += ds;
    th = next;
    worst = std::max(worst, std::abs(th));
    pulses_out->push_back({std::floor(sl / r.left_m_per_pulse), std::floor(sr / r.right_m_per_pulse)});
  }
  StraightRun run;
  run.length_m = std::hypot(x, y) + tape(rng);
  run.right_pulses = std::floor(sr / r.right_m_per_pulse);
  run.max_heading_deviation_rad = worst;
  run.shortening = 1 - std::hypot(x, y) / s;
  return run;
}

// A run whose heading wobbles with the given amplitude (two waves over its length).
StraightRun straightRun(const Robot& r, double length_m, double wobble_rad, unsigned seed,
                        std::vector<std::pair<double, double>>* pulses_out) {
  const double wavelength = length_m / 2;
  return straightRunWith(
      r, length_m, [&](double s) { return wobble_rad * std::sin(2 * M_PI * s / wavelength); },
      seed, pulses_out);
}

TEST(UahStraightRun, RejectsRunsThatStrayAndAveragesTheRest) {
  const Robot r = knownRobot();
  std::vector<std::pair<double, double>> pulses;
  std::vector<StraightRun> runs;
  for (unsigned i = 0; i < 4; ++i)
    runs.push_back(straightRun(r, 3.0, 0.01 + 0.005 * i, i, &pulses));
  runs.push_back(straightRun(r, 3.0, 0.15, 9, &pulses));  // 8.6° wobble
  const MmPerPulseEstimate e = estimateMmPerPulse(runs);
  EXPECT_EQ(e.accepted_runs.size(), 4u);
  ASSERT_EQ(e.rejected_runs.size(), 1u);
  EXPECT_EQ(e.rejected_runs[0], 4);
  EXPECT_NE(e.rejection_reasons[0].find("heading deviated"), std::string::npos);
  EXPECT_NEAR(e.right_m_per_pulse / r.right_m_per_pulse, 1.0, 0.003);
  // The rejected run alone would be off by far more than the accepted ones.
  const double wrong = runs[4].length_m / runs[4].right_pulses;
  EXPECT_GT(std::abs(wrong / r.right_m_per_pulse - 1), std::abs(e.right_m_per_pulse / r.right_m_per_pulse - 1));
  EXPECT_THROW(estimateMmPerPulse({runs[4]}), autocal::CalibrationError);
  EXPECT_THROW(estimateMmPerPulse({}), autocal::InputError);
}

// A run that lost distance against its pulses (here 1.2 %: a wheel rubbing a wall) is rejected
// against the others, which agree within the tape's and the pulses' resolution; the estimate is
// the others'. Runs that keep their heading and agree are all kept.
TEST(UahStraightRun, RejectsARunThatLostDistance) {
  const Robot r = knownRobot();
  std::vector<std::pair<double, double>> pulses;
  std::vector<StraightRun> runs;
  for (unsigned i = 0; i < 3; ++i) runs.push_back(straightRun(r, 3.0, 0.01, 20 + i, &pulses));
  EXPECT_EQ(estimateMmPerPulse(runs).accepted_runs.size(), 3u);
  runs[0].length_m *= 1 - 0.012;
  const MmPerPulseEstimate e = estimateMmPerPulse(runs);
  EXPECT_EQ(e.accepted_runs, (std::vector<int>{1, 2}));
  ASSERT_EQ(e.rejected_runs, (std::vector<int>{0}));
  EXPECT_NE(e.rejection_reasons[0].find("less distance per pulse"), std::string::npos)
      << e.rejection_reasons[0];
  EXPECT_NEAR(e.right_m_per_pulse / r.right_m_per_pulse, 1.0, 0.002);
}

// A wheel that starts late turns the robot by about 3° at the start of a run, and the heading
// comes back within 0.1 m: that costs the distance next to nothing, and the run is kept. A run
// that wobbles by 3.5° (two waves) all the way is shorter than its path by about 0.09 %, over a
// the paper's 2° bound as a distance (1 − cos 2°, 0.06 %), and is rejected though it never strayed 5°. The encoders' dead reckoning
// gives each run's shortening.
TEST(UahStraightRun, BoundsWhatTheHeadingCostsTheDistanceNotTheHeading) {
  const Robot r = knownRobot();
  DiffDriveParams p;
  p.left_m_per_pulse = r.left_m_per_pulse;
  p.right_m_per_pulse = r.right_m_per_pulse;
  p.wheelbase_m = r.b;
  const double deg = M_PI / 180;
  std::vector<std::pair<double, double>> late_pulses, wobbly_pulses, pulses;
  const StraightRun late = straightRunWith(
      r, 3.0, [&](double s) { return 6 * deg * std::exp(-s / 0.03) * (1 - std::exp(-s / 0.01)); },
      1, &late_pulses);
  const StraightRun wobbly = straightRun(r, 3.0, 3.5 * deg, 2, &wobbly_pulses);
  EXPECT_GT(late.max_heading_deviation_rad, 2 * deg);
  EXPECT_LT(late.shortening, 1e-4);
  EXPECT_GT(wobbly.shortening, 8e-4);
  EXPECT_LT(wobbly.max_heading_deviation_rad, 5 * deg);
  EXPECT_NEAR(pathShortening(late_pulses, p), late.shortening, 1e-4);
  EXPECT_NEAR(pathShortening(wobbly_pulses, p), wobbly.shortening, 1e-4);
  const StraightRun good = straightRun(r, 3.0, 0.01, 3, &pulses);
  const MmPerPulseEstimate e = estimateMmPerPulse({late, wobbly, good});
  EXPECT_EQ(e.accepted_runs, (std::vector<int>{0, 2}));
  ASSERT_EQ(e.rejected_runs, (std::vector<int>{1}));
  EXPECT_NE(e.rejection_reasons[0].find("shortened it by"), std::string::npos)
      << e.rejection_reasons[0];
}

TEST(UahStraightRun, HeadingDeviationFromEncoderPulses) {
  const Robot r = knownRobot();
  std::vector<std::pair<double, double>> pulses;
  const StraightRun run = straightRun(r, 3.0, 0.05, 1, &pulses);
  DiffDriveParams p;
  p.left_m_per_pulse = r.left_m_per_pulse;
  p.right_m_per_pulse = r.right_m_per_pulse;
  p.wheelbase_m = r.b;
  // Heading from encoders is quantised: one pulse of one wheel is c/b ≈ 0.015 rad (0.85°).
  EXPECT_NEAR(maxHeadingDeviationRad(pulses, p), run.max_heading_deviation_rad, 1.05 * r.right_m_per_pulse / r.b);
}

TEST(UahWheelbase, SpinVersusPivot) {
  const Robot r = knownRobot();
  const double spin = 2 * M_PI * r.b / (r.right_m_per_pulse + r.left_m_per_pulse);
  const double pivot = 2 * M_PI * r.b_pivot / r.right_m_per_pulse;
  const WheelbaseEstimate w = estimateWheelbase(spin, pivot, r.left_m_per_pulse, r.right_m_per_pulse);
  EXPECT_NEAR(w.wheelbase_m, r.b, 1e-12);
  EXPECT_NEAR(w.pivot_radius_m, r.b_pivot, 1e-12);
  EXPECT_NEAR(w.pivot_to_spin_ratio, 2 * 1.03 * (r.right_m_per_pulse + r.left_m_per_pulse) / (2 * r.right_m_per_pulse), 1e-9);
  EXPECT_THROW(estimateWheelbase(0, pivot, r.left_m_per_pulse, r.right_m_per_pulse), autocal::InputError);
}

TEST(Uah, WholeMethodOnSyntheticSignalsMeetsTheTolerances) {
  const Robot r = knownRobot();
  const Scene scene = irregularRoom();
  std::vector<double> right_left_stopped, left_right_stopped;
  for (unsigned k = 0; k < 3; ++k) {
    SignalOptions so;
    so.seed = 100 + k;
    right_left_stopped.push_back(detectWholeRound(turnSignal(r, scene, Turn::kPivotLeftStopped, so),
                                                  detectionOptions(kPivotExpected))
                                     .pulses_per_round);
    so.seed = 200 + k;
    left_right_stopped.push_back(
        detectWholeRound(turnSignal(r, scene, Turn::kPivotRightStopped, so),
                         detectionOptions(kPivotExpected))
            .pulses_per_round);
  }
  SignalOptions so;
  so.seed = 300;
  const double spin =
      detectWholeRound(turnSignal(r, scene, Turn::kSpin, so), detectionOptions(kSpinExpected))
          .pulses_per_round;
  std::vector<StraightRun> runs;
  std::vector<std::pair<double, double>> pulses;
  for (unsigned i = 0; i < 3; ++i)
    runs.push_back(straightRun(r, 3.0, 0.01 * (i + 1), 40 + i, &pulses));
  runs.push_back(straightRun(r, 3.0, 0.2, 50, &pulses));

  const UahResult u = computeUah(kNominal, right_left_stopped, left_right_stopped, runs, spin);
  const double Ed_true = r.right_m_per_pulse / r.left_m_per_pulse;
  const double ed_err = u.ed.Ed / Ed_true - 1;
  const double cR_err = u.calibrated.right_m_per_pulse / r.right_m_per_pulse - 1;
  const double cL_err = u.calibrated.left_m_per_pulse / r.left_m_per_pulse - 1;
  const double b_err = u.calibrated.wheelbase_m / r.b - 1;
  std::printf("[ figures  ] UAH errors: Ed %+.4f %%, right_m_per_pulse %+.4f %%, left_m_per_pulse %+.4f %%, b %+.4f %%\n",
              100 * ed_err, 100 * cR_err, 100 * cL_err, 100 * b_err);
  EXPECT_LT(std::abs(ed_err), 0.001);
  EXPECT_LT(std::abs(cR_err), 0.003);
  EXPECT_LT(std::abs(cL_err), 0.003);
  EXPECT_LT(std::abs(b_err), 0.003);
  EXPECT_EQ(u.straight.rejected_runs.size(), 1u);

  const OdometryCalibration c = u.toOdometryCalibration("bot");
  EXPECT_NO_THROW(checkOdometryCalibration(c));
  EXPECT_NEAR(u.multipliers().wheel_separation_multiplier, c.Eb, 1e-12);
  EXPECT_NEAR(c.multipliers().wheel_separation_multiplier, u.calibrated.wheelbase_m / 0.102, 1e-12);
  EXPECT_NEAR(c.multipliers().right_wheel_radius_multiplier, 1.004, 0.003);
  EXPECT_NEAR(c.multipliers().left_wheel_radius_multiplier, 0.999, 0.003);
}

}  // namespace
