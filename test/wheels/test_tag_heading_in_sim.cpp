// The tag detector and the heading from floor tags on the simulator's rendered frames, against the
// simulator's true robot pose (paper 000 §3.3–3.4; issue: within 0.5° of the truth).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "autocal/markers/tag_detector.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/wheels/tag_heading.h"

using namespace autocal;

namespace {

sim::RobotConfig robotConfig(const std::string& name) {
  return sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/" + name);
}
sim::WorldConfig defaultWorld() {
  return sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world.yaml");
}

wheels::CameraMount mountOf(const sim::CameraConfig& c) {
  wheels::CameraMount m;
  m.height_m = c.height_m;
  m.pitch_rad = c.pitch_rad;
  m.x_m = c.x_m;
  m.y_m = c.y_m;
  return m;
}

/// The robot's true heading relative to the tag's up (its −y axis: yaw + π/2 on the floor plan).
double trueHeading(const sim::FloorTagConfig& tag, const Pose2D& robot) {
  return wheels::wrapAngle(robot.yaw_rad - (tag.pose.yaw_rad + M_PI / 2));
}

struct Result {
  int frames = 0, frames_with_tags = 0;
  double worst_heading_error_rad = 0;
  double worst_position_error_m = 0;
};

/// Renders the default world's tag strip from poses around the aligned start and measures.
Result measureOverPoses(const sim::RobotConfig& robot, const wheels::CameraMount& mount,
                        bool undistort) {
  const sim::WorldConfig world = defaultWorld();
  sim::RenderOptions ro;
  ro.supersampling = robot.camera.supersampling;
  ro.noise_sigma = robot.camera.noise_sigma;
  sim::Renderer renderer(robot.camera, world, ro);
  markers::TagDetectorOptions o;
  CameraIntrinsics K = robot.camera.truth;
  if (!undistort) K.distortion_coefficients.assign(K.distortion_coefficients.size(), 0.0);
  markers::TagDetector detector(o, K);
  detector.setFloorNormal(mount.floorUpInCamera());
  wheels::HeadingOptions ho;
  std::mt19937_64 rng(3);
  Result r;
  // Facing the strip (−x) at several distances, offsets and headings up to ±15°.
  for (double x : {0.0, -0.2, -0.45}) {
    for (double y : {-0.03, 0.04}) {
      for (double dyaw_deg : {-15.0, -6.0, -1.0, 0.0, 2.5, 9.0, 15.0}) {
        const Pose2D pose{x, y, M_PI + dyaw_deg * M_PI / 180};
        const cv::Mat image = renderer.render({pose}, rng);
        const std::vector<markers::TagDetection> dets = detector.detect(image);
        std::vector<wheels::TagSighting> sightings;
        for (const auto& d : dets) {
          EXPECT_GE(d.id, 0);
          EXPECT_LT(d.id, static_cast<int>(world.floor_tags.size()));
          if (d.id < 0 || d.id >= static_cast<int>(world.floor_tags.size())) continue;
          const wheels::TagSighting s = wheels::sightTag(d, mount);
          sightings.push_back(s);
          // The tag's position in the robot frame, against the truth.
          const sim::FloorTagConfig& tag = world.floor_tags[d.id];
          const double dx = tag.pose.x_m - pose.x_m, dy = tag.pose.y_m - pose.y_m;
          const double c = std::cos(pose.yaw_rad), sn = std::sin(pose.yaw_rad);
          const double tx = c * dx + sn * dy, ty = -sn * dx + c * dy;
          if (s.distance_m < ho.max_distance_m) {
            r.worst_position_error_m =
                std::max(r.worst_position_error_m, std::hypot(s.x_m - tx, s.y_m - ty));
          }
        }
        ++r.frames;
        const wheels::HeadingMeasurement m = wheels::measureHeading(sightings, ho);
        if (!m.valid) continue;
        ++r.frames_with_tags;
        const double err =
            std::abs(wheels::wrapAngle(m.heading_rad - trueHeading(world.floor_tags[0], pose)));
        r.worst_heading_error_rad = std::max(r.worst_heading_error_rad, err);
      }
    }
  }
  return r;
}

}  // namespace

TEST(TagHeadingInSim, DefaultRobotHeadingWithinHalfADegree) {
  const sim::RobotConfig robot = robotConfig("robot_ideal.yaml");
  const Result r = measureOverPoses(robot, mountOf(robot.camera), true);
  std::cout << "default: " << r.frames_with_tags << "/" << r.frames
            << " frames with tags, worst heading error " << r.worst_heading_error_rad * 180 / M_PI
            << " deg, worst position error " << r.worst_position_error_m * 1000 << " mm"
            << std::endl;
  EXPECT_EQ(r.frames_with_tags, r.frames);
  EXPECT_LT(r.worst_heading_error_rad, 0.5 * M_PI / 180);
  EXPECT_LT(r.worst_position_error_m, 0.01);
}

TEST(TagHeadingInSim, WideLensHeadingWithinHalfADegree) {
  const sim::RobotConfig robot = robotConfig("fleet/robot_wide.yaml");
  const Result r = measureOverPoses(robot, mountOf(robot.camera), true);
  std::cout << "wide: " << r.frames_with_tags << "/" << r.frames
            << " frames with tags, worst heading error " << r.worst_heading_error_rad * 180 / M_PI
            << " deg" << std::endl;
  EXPECT_EQ(r.frames_with_tags, r.frames);
  EXPECT_LT(r.worst_heading_error_rad, 0.5 * M_PI / 180);
}

TEST(TagHeadingInSim, NominalMountOffByACentimetreAndADegreeStillWithinHalfADegree) {
  // The node uses the DB21's nominal mount, not the true one: a mount error changes the heading
  // only in the second order.
  const sim::RobotConfig robot = robotConfig("robot_ideal.yaml");
  wheels::CameraMount mount = mountOf(robot.camera);
  mount.pitch_rad += M_PI / 180;
  mount.height_m += 0.01;
  mount.x_m -= 0.01;
  const Result r = measureOverPoses(robot, mount, true);
  EXPECT_LT(r.worst_heading_error_rad, 0.5 * M_PI / 180);
}

TEST(TagHeadingInSim, PoseFromDistortedCornersIsWorseOnAWideLens) {
  // Why the detector undistorts first: treating the wide lens as a pinhole misplaces the tags.
  const sim::RobotConfig robot = robotConfig("fleet/robot_wide.yaml");
  const Result raw = measureOverPoses(robot, mountOf(robot.camera), false);
  const Result good = measureOverPoses(robot, mountOf(robot.camera), true);
  std::cout << "wide lens, raw corners: worst position error " << raw.worst_position_error_m * 1000
            << " mm (undistorted: " << good.worst_position_error_m * 1000 << " mm)" << std::endl;
  EXPECT_GT(raw.worst_position_error_m, 3 * good.worst_position_error_m);
}
