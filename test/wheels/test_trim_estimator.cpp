// The trim estimator of paper 000 §3.4 against a closed-form robot: a right wheel c times as fast
// as commanded turns the robot by Δθ = R(c·k − 1)φ_l/L per drive; straight needs k = 1/c.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "autocal/errors.h"
#include "autocal/wheels/trim_estimator.h"

using namespace autocal;

namespace {

struct Outcome {
  double ratio = 1;
  int drives = 0;
};

/// Drives until converged; `noise_rad` is the heading measurement's noise (two readings per drive).
Outcome calibrate(double c, double noise_rad, uint64_t seed, wheels::TrimEstimatorOptions o = {}) {
  wheels::TrimEstimator est(o);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, noise_rad);
  const double phi = 0.5 / o.wheel_radius_m;  // a 0.5 m drive
  while (!est.converged()) {
    const double dtheta =
        o.wheel_radius_m * (c * est.ratio() - 1) * phi / o.wheelbase_m + noise(rng) - noise(rng);
    est.addDrive(dtheta, phi);
  }
  return {est.ratio(), est.iterations()};
}

}  // namespace

TEST(TrimEstimator, OneNoiselessDriveGivesTheExactCorrection) {
  wheels::TrimEstimatorOptions o;
  wheels::TrimEstimator est(o);
  const double c = 1.1;
  const double phi = 10;
  const auto& it = est.addDrive(o.wheel_radius_m * (c - 1) * phi / o.wheelbase_m, phi);
  EXPECT_NEAR(it.k_i, 1.1, 1e-12);
  EXPECT_NEAR(est.ratio(), 1 / c, 1e-12);  // far from straight: the full step
}

TEST(TrimEstimator, RebasedRatioConvergesInTheNewModelWithItsHistoryScaled) {
  // The same duties are ratio r in the old model and s·r in the new one: a robot whose true factor
  // is c·r in the old model is (c/s)·r' in the new one, and must converge to s/c.
  wheels::TrimEstimatorOptions o;
  wheels::TrimEstimator est(o);
  const double c = 1.06, s = 1.05, phi = 10;
  auto drive = [&](double factor) {
    est.addDrive(o.wheel_radius_m * (factor * est.ratio() - 1) * phi / o.wheelbase_m, phi);
  };
  drive(c);
  const double before = est.history().front().ratio_after;
  est.rebase(s * est.ratio());
  EXPECT_NEAR(est.history().front().ratio_after, s * before, 1e-12);
  EXPECT_NEAR(est.history().front().ratio_before, s * 1.0, 1e-12);
  while (!est.converged()) drive(c / s);
  EXPECT_NEAR(est.ratio(), s / c, 1e-4);
  EXPECT_THROW(est.rebase(0.0), InputError);
  EXPECT_THROW(est.rebase(std::nan("")), InputError);
}

TEST(TrimEstimator, NearStraightTheUpdateIsThePapersHalfStep) {
  wheels::TrimEstimatorOptions o;
  wheels::TrimEstimator est(o);
  const double c = 1.004, phi = 10;
  est.addDrive(o.wheel_radius_m * (c - 1) * phi / o.wheelbase_m, phi);
  EXPECT_NEAR(est.ratio(), 1 + 0.5 * (1 / c - 1), 1e-12);
}

TEST(TrimEstimator, ConvergesOverTheFleetsRangeWithinTenDrives) {
  // Trims from −0.09 to +0.08 (5th..95th percentile of 103 Duckiebots): one wheel up to ~20 %
  // stronger. Heading noise 0.1° per reading.
  const double noise = 0.1 * M_PI / 180;
  for (double c : {0.82, 0.9, 0.97, 1.0, 1.03, 1.1, 1.2}) {
    for (uint64_t seed : {1, 2, 3}) {
      const Outcome r = calibrate(c, noise, seed);
      EXPECT_LE(r.drives, 10) << "c " << c;
      // Residual speed mismatch below 0.1 %: less than 2 cm of drift over 2 m on a 0.1 m wheelbase.
      EXPECT_NEAR(r.ratio * c, 1.0, 0.001) << "c " << c << " seed " << seed;
    }
  }
}

TEST(TrimEstimator, ThePapersDampedStepAloneConvergesTooButSlower) {
  wheels::TrimEstimatorOptions o;
  o.full_step_above = 1.0;  // never the full step: the paper as written
  o.max_iterations = 30;
  const Outcome paper = calibrate(1.2, 0, 1, o);
  const Outcome ours = calibrate(1.2, 0, 1);
  EXPECT_NEAR(paper.ratio * 1.2, 1.0, 0.001);
  EXPECT_GT(paper.drives, ours.drives);
}

TEST(TrimEstimator, AnImplausibleDriveIsRejectedNotAveraged) {
  wheels::TrimEstimatorOptions o;
  wheels::TrimEstimator est(o);
  const double phi = 10;                         // a 0.32 m drive
  const auto& it = est.addDrive(M_PI / 2, phi);  // a tag read at 90°
  EXPECT_TRUE(it.rejected);
  EXPECT_DOUBLE_EQ(est.ratio(), 1.0);
  est.addDrive(o.wheel_radius_m * 0.05 * phi / o.wheelbase_m, phi);
  EXPECT_NEAR(est.ratio(), 1 / 1.05, 1e-12);
}

TEST(TrimEstimator, RepeatedImplausibleDrivesFail) {
  wheels::TrimEstimator est{wheels::TrimEstimatorOptions()};
  est.addDrive(1.5, 10);
  est.addDrive(1.5, 10);
  EXPECT_THROW(est.addDrive(1.5, 10), CalibrationError);
}

TEST(TrimEstimator, ADivergingRatioFails) {
  wheels::TrimEstimatorOptions o;
  o.max_ratio_deviation = 0.1;
  wheels::TrimEstimator est(o);
  const double phi = 15;
  EXPECT_THROW(est.addDrive(o.wheel_radius_m * 0.3 * phi / o.wheelbase_m, phi), CalibrationError);
}

TEST(TrimEstimator, NoConvergenceWithinTheBoundFails) {
  wheels::TrimEstimatorOptions o;
  o.max_iterations = 4;
  o.mean_of_drives = 0;  // the paper's rule alone
  wheels::TrimEstimator est(o);
  const double phi = 15;
  // A heading change that alternates sign never lets the updates fall below E.
  EXPECT_NO_THROW(est.addDrive(0.1, phi));
  EXPECT_NO_THROW(est.addDrive(-0.1, phi));
  EXPECT_NO_THROW(est.addDrive(0.1, phi));
  EXPECT_THROW(est.addDrive(-0.1, phi), CalibrationError);
  // With the mean: more_drives_for_mean more, and the mean of the last four is far from sure.
  o.mean_of_drives = 4;
  o.more_drives_for_mean = 2;
  wheels::TrimEstimator meaned(o);
  for (int i = 0; i < 5; ++i) EXPECT_NO_THROW(meaned.addDrive(i % 2 ? -0.1 : 0.1, phi));
  EXPECT_THROW(meaned.addDrive(-0.1, phi), CalibrationError);
}

TEST(TrimEstimator, BadInputAndOptions) {
  wheels::TrimEstimator est{wheels::TrimEstimatorOptions()};
  EXPECT_THROW(est.addDrive(NAN, 10), InputError);
  EXPECT_THROW(est.addDrive(0.1, 0), InputError);
  wheels::TrimEstimatorOptions o;
  o.damping = 0;
  EXPECT_THROW(o.validate(), ConfigError);
}

// Wheels that slip at random make each drive's heading scatter by more than E allows three times
// in a row; after max_iterations the mean of the last drives' ratios is the result when it is sure
// enough, and the stage fails, saying why, when it is not.
TEST(TrimEstimator, ScatteredDrivesEndInTheMeanOfTheLastOnesWhenItIsSureEnough) {
  const double c = 1.03, noise_rad = 0.004;  // 0.23° per reading
  int meaned = 0;
  double worst = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    wheels::TrimEstimatorOptions paper;
    paper.mean_of_drives = 0;
    bool paper_failed = false;
    try {
      calibrate(c, noise_rad, seed, paper);
    } catch (const CalibrationError&) {
      paper_failed = true;
    }
    wheels::TrimEstimatorOptions o;
    const Outcome out = calibrate(c, noise_rad, seed, o);
    if (paper_failed) {
      ++meaned;
      EXPECT_GE(out.drives, o.max_iterations);
      EXPECT_LE(out.drives, o.max_iterations + o.more_drives_for_mean);
    }
    worst = std::max(worst, std::abs(out.ratio * c - 1));
  }
  EXPECT_GE(meaned, 5) << "the noise should often defeat the paper's rule";
  // Twelve 0.5 m drives, each's ratio ±0.0011 (two readings of 0.004 rad): the mean within ~3
  // sigma.
  EXPECT_LT(worst, 0.001);

  wheels::TrimEstimatorOptions o;
  try {
    calibrate(c, 0.02, 3, o);
    ADD_FAILURE() << "a heading scattering by 1.1° per reading should not give a ratio";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("the heading scatters from drive to drive"),
              std::string::npos)
        << e.what();
  }
}

// Where twelve drives' mean is about as sure as max_mean_error allows (0.32° per reading), each
// drive beyond max_iterations joins the mean, whose standard error falls as 1/√n: every seed ends
// with a ratio (with the last twelve drives' mean alone, 2 of these 40 seeds failed; at 0.37° per
// reading 10 of 40, against 2 with the growing mean).
TEST(TrimEstimator, TheMeanTakesEveryDriveBeyondTheBoundUntilItIsSure) {
  const double c = 1.03, noise_rad = 0.0055;
  wheels::TrimEstimatorOptions o;
  int beyond = 0;
  double worst = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    Outcome out;
    try {
      out = calibrate(c, noise_rad, seed, o);
    } catch (const CalibrationError& e) {
      ADD_FAILURE() << "seed " << seed << ": " << e.what();
      continue;
    }
    if (out.drives > o.max_iterations) ++beyond;
    worst = std::max(worst, std::abs(out.ratio * c - 1));
  }
  std::printf("%d of 40 seeds needed drives beyond max_iterations; worst ratio error %.5f\n",
              beyond, worst);
  EXPECT_GE(beyond, 5) << "the scatter should often need more than twelve drives' mean";
  EXPECT_LT(worst, 3 * 0.0018 / std::sqrt(12.0));
}

// The ratio the drives measure can move during the iteration: the tags under the robot's later
// drives laid otherwise (a tag turned by a degree reads as a turn of the robot), the motors
// warming. Here it moves by 1 % over drives 6-18. The early drives then disagree with the late
// ones, and the mean of them all is not sure however many join it; the latest drives' mean is,
// and it is the ratio the robot has at the end.
TEST(TrimEstimator, ARatioThatMovedEndsInTheMeanOfTheLatestDrives) {
  const double noise_rad = 0.004;  // 0.23° per reading, as above
  const auto c_of_drive = [](int drive) {
    return 1.03 + 0.0103 * std::clamp((drive - 6) / 12.0, 0.0, 1.0);
  };
  double worst = 0;
  int beyond = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    wheels::TrimEstimatorOptions o;
    wheels::TrimEstimator est(o);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0, noise_rad);
    const double phi = 0.5 / o.wheel_radius_m;
    double c = c_of_drive(0);
    try {
      while (!est.converged()) {
        c = c_of_drive(est.iterations());
        const double dtheta = o.wheel_radius_m * (c * est.ratio() - 1) * phi / o.wheelbase_m +
                              noise(rng) - noise(rng);
        est.addDrive(dtheta, phi);
      }
    } catch (const CalibrationError& e) {
      ADD_FAILURE() << "seed " << seed << ": " << e.what();
      continue;
    }
    if (est.iterations() > o.max_iterations) ++beyond;
    worst = std::max(worst, std::abs(est.ratio() * c - 1));
  }
  std::printf("%d of 20 seeds needed drives beyond max_iterations; worst error against the ratio "
              "of the last drive %.5f\n", beyond, worst);
  EXPECT_GE(beyond, 10) << "the moving ratio should keep most seeds beyond max_iterations";
  // The latest drives' mean: within a quarter of the move of the ratio the robot ends with (the
  // mean lags by the part of the move still in its window; a seed whose updates fell below E
  // before the ratio moved converged on the ratio it had then). The mean of every drive since the
  // first full step would be about half the move off.
  EXPECT_LT(worst, 0.0025);
}

