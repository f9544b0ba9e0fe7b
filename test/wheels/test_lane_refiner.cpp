// LaneRefiner's logic (paper 000 §5.2) on synthetic sightings: a kinematic robot whose right wheel
// is truly c times its command drives through the refiner's car commands; each frame sights the
// segment's tags with the true heading plus noise. The refiner never sees c; the test does.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "autocal/errors.h"
#include "autocal/wheels/lane_refiner.h"

using namespace autocal;
using namespace autocal::wheels;

namespace {

constexpr double kR = 0.0318, kL = 0.1;

/// The trim that drives straight a robot whose right wheel turns c times as fast as commanded.
double trueTrim(double c) { return trimFromSpeedRatio(1.0 / c, 1.0); }

struct World {
  int first_id = 100;
  int tags = 8;
  double first_x_m = 0.6;
  double spacing_m = 0.15;
  int missing_from = -1;  ///< tags from this index on are not there (-1: all are)
};

class SyntheticLane {
 public:
  SyntheticLane(double c, uint64_t seed) : c_(c), rng_(seed) {}

  /// Drives one pass from (0, y, yaw): straight ahead at 0.2 m/s through `kin` until the refiner
  /// takes over, until its pass ended or `max_s`. Returns whether a pass ended; `max_abs_y` the
  /// largest lateral offset.
  bool runPass(LaneRefiner& refiner, KinematicsParams& kin, const World& world, double y,
               double yaw, double max_s = 20.0) {
    x_ = 0;
    y_ = y;
    yaw_ = yaw;
    const size_t before = refiner.passes().size();
    const double t0 = t_;
    while (t_ - t0 < max_s) {
      if (std::fmod(t_ + 1e-9, 1.0 / 30) < 0.01) {
        refiner.addEncoders(t_, static_cast<int>(std::floor(left_ / (2 * M_PI / 135))),
                            static_cast<int>(std::floor(right_ / (2 * M_PI / 135))), 135);
        refiner.addSightings(t_, sight(world));
      }
      const LaneOutput o = refiner.update(t_);
      if (std::getenv("AUTOCAL_TRACE") && std::fmod(t_ + 1e-9, 0.25) < 0.01)
        std::fprintf(stderr, "t %.2f x %.3f y %.3f yaw %.3f: %s\n", t_, x_, y_, yaw_,
                     refiner.describe().c_str());
      if (o.apply) kin.trim = o.trim;
      if (refiner.passes().size() > before) {
        last_output_ = refiner.update(t_ + 0.01);
        return true;
      }
      if (refiner.inPass()) {
        EXPECT_TRUE(o.commanding);
      }
      const CarCommand cmd = o.commanding ? o.cmd : CarCommand{0.2, 0.0};
      step(carCmdToDuties(kin, cmd), 0.01);
      max_abs_y = std::max(max_abs_y, std::abs(y_));
    }
    return false;
  }

  std::vector<TagSighting> sight(const World& w) {
    std::vector<TagSighting> out;
    std::normal_distribution<double> noise(0.0, 0.003);
    for (int i = 0; i < w.tags; ++i) {
      if (w.missing_from >= 0 && i >= w.missing_from) continue;
      const double dx = w.first_x_m + i * w.spacing_m - x_, dy = -y_;
      TagSighting s;
      s.id = w.first_id + i;
      s.x_m = std::cos(yaw_) * dx + std::sin(yaw_) * dy;
      s.y_m = -std::sin(yaw_) * dx + std::cos(yaw_) * dy;
      if (s.x_m < 0.14 || s.x_m > 0.5 || std::abs(s.y_m) > 0.5 * s.x_m) continue;
      s.heading_rad = yaw_ + heading_bias + noise(rng_);
      s.distance_m = std::hypot(s.x_m - 0.055, s.y_m, 0.105);
      out.push_back(s);
    }
    return out;
  }

  double max_abs_y = 0;
  double heading_bias = 0;
  double c_;
  LaneOutput last_output_;

 private:
  void step(const WheelDuties& d, double dt) {
    const double wl = d.left * 27.0, wr = c_ * d.right * 27.0;
    left_ += wl * dt;
    right_ += wr * dt;
    const double v = kR * (wl + wr) / 2, w = kR * (wr - wl) / kL;
    x_ += v * std::cos(yaw_) * dt;
    y_ += v * std::sin(yaw_) * dt;
    yaw_ += w * dt;
    t_ += dt;
  }
  std::mt19937_64 rng_;
  double t_ = 0, x_ = 0, y_ = 0, yaw_ = 0, left_ = 0, right_ = 0;
};

LaneRefinerOptions options(double trim) {
  LaneRefinerOptions o;
  o.kinematics.trim = trim;
  o.num_tags = 8;
  return o;
}

}  // namespace

TEST(LaneRefiner, AppliesOnlyOnceStableAndDifferent) {
  const double c = 0.96;  // the right wheel 4 % weak: true trim 0.0204
  LaneRefinerOptions o = options(trueTrim(c) + 0.05);
  KinematicsParams kin = o.kinematics;
  LaneRefiner refiner(o);
  SyntheticLane lane(c, 1);
  for (int pass = 1; pass <= 4; ++pass) {
    ASSERT_TRUE(lane.runPass(refiner, kin, World(), 0.01 * (pass % 2), 0.02));
    const LanePass& p = refiner.passes().back();
    ASSERT_FALSE(p.aborted) << p.reason;
    ASSERT_TRUE(p.estimated) << p.reason;
    EXPECT_GE(p.parts.size(), 5u);
    EXPECT_NEAR(p.estimate, trueTrim(c), 0.002) << "pass " << pass;
    // Passes 1 and 2 are not yet stable over stable_passes (3); pass 3 applies; pass 4 agrees.
    EXPECT_EQ(p.applied, pass == 3) << "pass " << pass;
    EXPECT_FALSE(lane.last_output_.commanding);  // after a pass: the lane follower drives
  }
  EXPECT_EQ(refiner.applications(), 1);
  EXPECT_NEAR(kin.trim, trueTrim(c), 0.002);
  EXPECT_DOUBLE_EQ(refiner.currentTrim(), kin.trim);
  EXPECT_LT(lane.max_abs_y, 0.05);
}

TEST(LaneRefiner, RightTrimIsNotChanged) {
  const double c = 1.03;
  LaneRefinerOptions o = options(trueTrim(c));
  KinematicsParams kin = o.kinematics;
  LaneRefiner refiner(o);
  SyntheticLane lane(c, 2);
  for (int pass = 0; pass < 4; ++pass) ASSERT_TRUE(lane.runPass(refiner, kin, World(), 0, 0));
  EXPECT_EQ(refiner.applications(), 0);
  EXPECT_EQ(kin.trim, o.kinematics.trim);
  for (const auto& p : refiner.passes()) EXPECT_TRUE(p.estimated);
}

TEST(LaneRefiner, EstimatesThatDoNotAgreeAreNotApplied) {
  // The robot changes between passes (a wheel slipping on one pass): the estimates scatter by
  // more than stable_tolerance, so nothing is applied although each differs from the trim in use.
  LaneRefinerOptions o = options(0.0);
  KinematicsParams kin = o.kinematics;
  LaneRefiner refiner(o);
  SyntheticLane lane(0.96, 3);
  for (double c : {0.96, 0.94, 0.96, 0.94}) {
    lane.c_ = c;
    ASSERT_TRUE(lane.runPass(refiner, kin, World(), 0, 0));
  }
  EXPECT_EQ(refiner.applications(), 0);
  EXPECT_EQ(kin.trim, 0.0);
}

TEST(LaneRefiner, TagsLostMidPassAbortAndNothingIsApplied) {
  const double c = 0.96;
  LaneRefinerOptions o = options(0.0);
  KinematicsParams kin = o.kinematics;
  LaneRefiner refiner(o);
  SyntheticLane lane(c, 4);
  World broken;
  broken.missing_from = 4;  // the segment's last four tags are gone
  for (int pass = 0; pass < 3; ++pass) {
    ASSERT_TRUE(lane.runPass(refiner, kin, broken, 0, 0));
    EXPECT_TRUE(refiner.passes().back().aborted);
    EXPECT_FALSE(refiner.passes().back().estimated);
    EXPECT_FALSE(lane.last_output_.commanding);  // the abort stops commanding at once
  }
  EXPECT_EQ(refiner.applications(), 0);
  EXPECT_EQ(kin.trim, 0.0);
  // With the segment's length unknown, the same loss is the segment's end: estimates, applied
  // after three.
  o.num_tags = 0;
  LaneRefiner any(o);
  for (int pass = 0; pass < 3; ++pass) ASSERT_TRUE(lane.runPass(any, kin, broken, 0, 0));
  EXPECT_EQ(any.applications(), 1);
  EXPECT_NEAR(kin.trim, trueTrim(c), 0.003);
}

TEST(LaneRefiner, HeadingBeyondBoundAborts) {
  LaneRefinerOptions o = options(0.0);
  LaneRefiner refiner(o);
  TagSighting s;
  s.id = 100;
  s.x_m = 0.3;
  s.distance_m = std::hypot(0.245, 0.105);
  refiner.addEncoders(0, 0, 0, 135);
  refiner.addSightings(0.0, {s});
  ASSERT_TRUE(refiner.inPass());
  EXPECT_TRUE(refiner.update(0.01).commanding);
  s.heading_rad = 0.5;  // a bad read, or the robot turned away
  refiner.addSightings(0.03, {s});
  EXPECT_FALSE(refiner.update(0.04).commanding);
  ASSERT_EQ(refiner.passes().size(), 1u);
  EXPECT_TRUE(refiner.passes()[0].aborted);
}

TEST(LaneRefiner, StartsOnlyOnTheFirstTagNearStraightAhead) {
  LaneRefinerOptions o = options(0.0);
  LaneRefiner refiner(o);
  TagSighting s;
  s.x_m = 0.3;
  s.distance_m = std::hypot(0.245, 0.105);
  s.id = 101;  // not the first
  refiner.addSightings(0.0, {s});
  EXPECT_FALSE(refiner.inPass());
  s.id = 100;
  s.heading_rad = 0.5;  // not driving along the lane
  refiner.addSightings(0.1, {s});
  EXPECT_FALSE(refiner.inPass());
  s.heading_rad = 0;
  s.y_m = 0.12;  // beside the segment (another lane)
  refiner.addSightings(0.2, {s});
  EXPECT_FALSE(refiner.inPass());
  EXPECT_FALSE(refiner.update(0.25).commanding);  // idle: the lane follower drives
  s.y_m = 0.01;
  refiner.addSightings(0.3, {s});
  EXPECT_TRUE(refiner.inPass());
}

TEST(LaneRefiner, OptionsNameTheBadKey) {
  LaneRefinerOptions o;
  o.stable_passes = 0;
  try {
    o.validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("stable_passes"), std::string::npos);
  }
  o = LaneRefinerOptions();
  o.speed_mps = -1;
  EXPECT_THROW(LaneRefiner r(o), ConfigError);
}
