// The camera's mount from the floor tags alone (extrinsics::mountFromTags) on the simulator: the
// robot stands on the tag strip of world.yaml, turns on the spot and drives straight forward and
// back; each still's tags are detected on the rendered frame with the tag size. The mount is
// judged by the simulator's truth (support/floor_truth.h): four mounts, each with every degree of
// freedom a real one has.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "autocal/errors.h"
#include "autocal/extrinsics/tag_mount.h"
#include "autocal/markers/tag_detector.h"
#include "autocal/sim/config.h"
#include "autocal/sim/floor_truth.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "support/camera_mounts.h"

namespace {

using namespace autocal;

const std::string kConfigDir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";

sim::RobotConfig mountNumber(int i) {
  sim::RobotConfig r = sim::loadRobotConfig(kConfigDir + "robot_ideal.yaml");
  test::setCameraMount(r, i);
  return r;
}

/// The robot's stills and motions, as the stage would make them.
struct Recorded {
  std::vector<extrinsics::TagStill> stills;
  std::vector<extrinsics::StillPair> pairs;
};

/// The motions of record(): a drive forward and one back; or short hops forward, the stage's
/// (the last turning, its right wheel faster).
enum class Drives { kLong, kHops };

Recorded record(const sim::RobotConfig& robot, uint64_t noise_seed = 11,
                Drives drives = Drives::kLong) {
  sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world.yaml");
  world.robot_start = {0.0, 0.0, M_PI};  // facing the tag strip
  sim::Simulation simulation(robot, world, sim::SimulationOptions());
  sim::RenderOptions render;
  render.supersampling = robot.camera.supersampling;
  render.noise_sigma = robot.camera.noise_sigma;
  sim::Renderer renderer(robot.camera, world, render);
  markers::TagDetectorOptions detector_options;
  detector_options.tag_size_m = 0.065;
  markers::TagDetector detector(detector_options, robot.camera.truth);
  // The floor's normal as the nominal mount has it (it picks the tags' pose among IPPE's two).
  const double pitch = 0.26;
  detector.setFloorNormal({0.0, -std::cos(pitch), -std::sin(pitch)});
  std::mt19937_64 rng(noise_seed);
  Recorded out;
  auto still = [&] {
    simulation.setDuty(0, 0);
    simulation.advance(1.0);
    extrinsics::TagStill s;
    for (const markers::TagDetection& d :
         detector.detect(renderer.render({simulation.pose()}, rng))) {
      extrinsics::TagSeen t;
      t.id = d.id;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) t.rotation(r, c) = d.rotation(r, c);
        t.translation_m[r] = d.translation_m[r];
      }
      t.size_m = detector_options.tag_size_m;
      s.tags.push_back(t);
    }
    out.stills.push_back(s);
  };
  auto move = [&](double left, double right, double seconds, extrinsics::StillMotion motion) {
    simulation.setDuty(left, right);
    simulation.advance(seconds);
    still();
    out.pairs.push_back(
        {static_cast<int>(out.stills.size()) - 2, static_cast<int>(out.stills.size()) - 1, motion});
  };
  using M = extrinsics::StillMotion;
  still();
  move(-0.16, 0.16, 0.3, M::kSpin);
  move(0.16, -0.16, 0.6, M::kSpin);
  move(-0.16, 0.16, 0.3, M::kSpin);
  if (drives == Drives::kHops) {
    // 0.12 m each; 0.304 on the right wheel drives robot_ideal.yaml's wheels straight.
    for (int hop = 0; hop < 4; ++hop) move(0.3, 0.304, 0.6, M::kForward);
    move(0.27, 0.34, 0.6, M::kForward);
    return out;
  }
  move(0.3, 0.3, 1.0, M::kForward);
  move(-0.3, -0.3, 1.0, M::kBackward);
  move(0.16, -0.16, 0.3, M::kSpin);
  move(-0.16, 0.16, 0.3, M::kSpin);
  return out;
}

class TagMountInSim : public ::testing::TestWithParam<int> {};

TEST_P(TagMountInSim, MountFromTagsWithinTheTargets) {
  const sim::RobotConfig robot = mountNumber(GetParam());
  const Recorded rec = record(robot);
  const extrinsics::TagMountResult r = extrinsics::mountFromTags(rec.stills, rec.pairs, {});
  const extrinsics::CameraMount& m = r.mount;
  const sim::CameraConfig& t = robot.camera;
  const extrinsics::CameraInfoRectification camera = sim::trueCameraInfo(robot);
  const sim::FloorError e = sim::floorError(robot, camera.rectified,
                                            extrinsics::homographyFromMount(m, camera.rectified));
  std::printf(
      "mount %d: %s; plane %.2f mm RMS over %d corners, %d drives (yaw spread %.3f deg), "
      "%d turns (centre %.2f mm)\n",
      GetParam(), sim::mountVersusTruth(e, m, t).c_str(), 1e3 * r.plane_rms_m, r.corners,
      r.straight, r.yaw_spread_rad * 180 / M_PI, r.spins, 1e3 * r.centre_rms_m);
  EXPECT_LE(e.rms_m, 0.01);
  EXPECT_LE(e.max_m, 0.02);
  const double deg = M_PI / 180;
  EXPECT_NEAR(m.height_m, t.height_m, 0.002);
  EXPECT_NEAR(m.pitch_rad, t.pitch_rad, 0.3 * deg);
  EXPECT_NEAR(m.roll_rad, t.roll_rad, 0.3 * deg);
  EXPECT_NEAR(m.yaw_rad, t.yaw_rad, 0.5 * deg);
  // The stated uncertainty (its scatter test is below): small enough to say the targets hold.
  ASSERT_TRUE(r.has_sigma);
  const extrinsics::CameraMount& s = r.sigma;
  std::printf(
      "  sigma: height %.2f mm, pitch %.3f deg, roll %.3f deg, yaw %.3f deg, x %.2f mm, y %.2f "
      "mm\n",
      1e3 * s.height_m, s.pitch_rad / deg, s.roll_rad / deg, s.yaw_rad / deg, 1e3 * s.x_m,
      1e3 * s.y_m);
  for (double sigma : {s.height_m, s.pitch_rad, s.roll_rad, s.yaw_rad, s.x_m, s.y_m})
    EXPECT_GT(sigma, 0);
  EXPECT_LT(s.height_m, 0.002 / 3);
  EXPECT_LT(s.pitch_rad, 0.3 * deg / 3);
  EXPECT_LT(s.roll_rad, 0.3 * deg / 3);
  EXPECT_LT(s.yaw_rad, 0.5 * deg / 3);
}

INSTANTIATE_TEST_SUITE_P(FourMounts, TagMountInSim, ::testing::Range(0, test::kCameraMounts));

TEST(TagMount, WithoutTurnsOrDrivesItSaysWhatIsMissing) {
  const Recorded rec = record(mountNumber(0));
  std::vector<extrinsics::StillPair> drives_only;
  for (const auto& p : rec.pairs)
    if (p.motion != extrinsics::StillMotion::kSpin) drives_only.push_back(p);
  try {
    extrinsics::mountFromTags(rec.stills, drives_only, {});
    FAIL() << "no error";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("turns on the spot"), std::string::npos) << e.what();
  }
  EXPECT_THROW(extrinsics::mountFromTags({}, {}, {}), CalibrationError);
}

TEST(TagMount, StraightOnlyTakesTheYawFromTheDrivesKnownToBeStraightAlone) {
  const Recorded rec = record(mountNumber(0));
  std::vector<extrinsics::StillPair> pairs = rec.pairs;
  for (auto& p : pairs) p.straight = p.motion == extrinsics::StillMotion::kForward;
  // Fewer straight drives than asked for: without straight_only every drive's chord counts ...
  extrinsics::TagMountOptions o;
  o.min_straight = 2;
  EXPECT_EQ(extrinsics::mountFromTags(rec.stills, pairs, o).straight, 2);
  // ... with it, the drive back is left out and the yaw is refused, saying why.
  o.straight_only = true;
  try {
    extrinsics::mountFromTags(rec.stills, pairs, o);
    FAIL() << "no error";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("known to be straight"), std::string::npos) << e.what();
  }
  o.min_straight = 1;
  EXPECT_EQ(extrinsics::mountFromTags(rec.stills, pairs, o).straight, 1);
}

// A hop the tags say turned (here by degrees, its right wheel faster) gives the yaw only through
// its measured turn, whose error the tags' lever multiplies: it counts only where too few hops
// stayed straight.
TEST(TagMount, AHopThatTurnedCountsOnlyWhereTooFewStayedStraight) {
  const sim::RobotConfig robot = mountNumber(0);
  const Recorded rec = record(robot, 11, Drives::kHops);
  std::vector<extrinsics::StillPair> pairs = rec.pairs;
  for (auto& p : pairs) p.straight = p.motion == extrinsics::StillMotion::kForward;
  extrinsics::TagMountOptions o;
  o.straight_only = true;
  o.min_straight = 3;
  const extrinsics::TagMountResult kept = extrinsics::mountFromTags(rec.stills, pairs, o);
  std::printf("hops taken as straight %d, yaw %.3f deg (truth %.3f), sigma %.3f deg\n",
              kept.straight, kept.mount.yaw_rad * 180 / M_PI, robot.camera.yaw_rad * 180 / M_PI,
              kept.sigma.yaw_rad * 180 / M_PI);
  EXPECT_EQ(kept.straight, 4);
  EXPECT_NEAR(kept.mount.yaw_rad, robot.camera.yaw_rad, 0.5 * M_PI / 180);
  o.min_straight = 5;
  EXPECT_EQ(extrinsics::mountFromTags(rec.stills, pairs, o).straight, 5);
}

}  // namespace

TEST(TagMount, StatedSigmaCoversTheScatterOverTheCamerasNoise) {
  // The same motions under the camera's noise of other seeds: the mounts found scatter by no more
  // than each one's stated sigma, and by not much less (the jackknife over the stills also counts
  // how the tags' place in the image moves the result, which the seeds do not change).
  const sim::RobotConfig robot = mountNumber(0);
  std::vector<extrinsics::TagMountResult> runs;
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    const Recorded rec = record(robot, seed);
    runs.push_back(extrinsics::mountFromTags(rec.stills, rec.pairs, {}));
    ASSERT_TRUE(runs.back().has_sigma);
  }
  const double n = static_cast<double>(runs.size());
  auto check = [&](const char* name, double (*field)(const extrinsics::CameraMount&)) {
    double mean = 0, stated = 0;
    for (const auto& r : runs) mean += field(r.mount) / n, stated += field(r.sigma) / n;
    double sq = 0;
    for (const auto& r : runs) sq += std::pow(field(r.mount) - mean, 2);
    const double scatter = std::sqrt(sq / (n - 1));
    std::printf("%s: scatter %.3g, stated sigma %.3g (mean of %d)\n", name, scatter, stated,
                static_cast<int>(n));
    EXPECT_LE(scatter, 1.5 * stated) << name;
    EXPECT_LE(stated, 8 * scatter) << name;
  };
  check("height_m", [](const extrinsics::CameraMount& m) { return m.height_m; });
  check("pitch_rad", [](const extrinsics::CameraMount& m) { return m.pitch_rad; });
  check("roll_rad", [](const extrinsics::CameraMount& m) { return m.roll_rad; });
  check("yaw_rad", [](const extrinsics::CameraMount& m) { return m.yaw_rad; });
  check("x_m", [](const extrinsics::CameraMount& m) { return m.x_m; });
  check("y_m", [](const extrinsics::CameraMount& m) { return m.y_m; });
}
