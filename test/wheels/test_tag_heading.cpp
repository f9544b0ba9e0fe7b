// The heading from tag poses and its outlier rejection, on constructed poses (closed form).
#include <gtest/gtest.h>

#include <cmath>

#include "autocal/markers/tag_detector.h"
#include "autocal/wheels/tag_heading.h"

using namespace autocal;

namespace {

/// A floor tag seen by a robot whose heading relative to the tag's up is `heading_rad`, the tag
/// centre at (x, y) in the robot frame.
markers::TagDetection tagSeenAt(const wheels::CameraMount& mount, double heading_rad, double x,
                                double y) {
  // Tag axes in the robot frame: up = rotation of the robot's x by −heading; y = −up; z = down.
  const cv::Vec3d up(std::cos(-heading_rad), std::sin(-heading_rad), 0);
  const cv::Vec3d yaxis = -up, zaxis(0, 0, -1);
  const cv::Vec3d xaxis = yaxis.cross(zaxis);
  cv::Matx33d R_robot;
  for (int r = 0; r < 3; ++r) {
    R_robot(r, 0) = xaxis[r];
    R_robot(r, 1) = yaxis[r];
    R_robot(r, 2) = zaxis[r];
  }
  const cv::Matx33d R_rc = mount.cameraToRobot();
  markers::TagDetection d;
  d.id = 1;
  d.rotation = R_rc.t() * R_robot;
  d.translation_m =
      R_rc.t() * (cv::Vec3d(x, y, 0) - cv::Vec3d(mount.x_m, mount.y_m, mount.height_m));
  return d;
}

}  // namespace

TEST(TagHeading, CameraFrameLooksAheadAndDown) {
  wheels::CameraMount m;
  const cv::Matx33d R = m.cameraToRobot();
  const cv::Vec3d z = R * cv::Vec3d(0, 0, 1), x = R * cv::Vec3d(1, 0, 0);
  EXPECT_NEAR(z[0], std::cos(m.pitch_rad), 1e-12);
  EXPECT_NEAR(z[2], -std::sin(m.pitch_rad), 1e-12);
  EXPECT_NEAR(x[1], -1, 1e-12);  // optical x = the robot's right
  EXPECT_NEAR(cv::determinant(R), 1, 1e-12);
  const cv::Vec3d up = m.floorUpInCamera();
  EXPECT_LT(up[1], 0);  // up is image-up (−y)
}

TEST(TagHeading, RecoversHeadingAndPositionOfConstructedTags) {
  wheels::CameraMount m;
  for (double h : {-1.0, -0.2, 0.0, 0.05, 0.7, 3.0}) {
    const wheels::TagSighting s = wheels::sightTag(tagSeenAt(m, h, 0.3, -0.04), m);
    EXPECT_NEAR(s.heading_rad, h, 1e-9);
    EXPECT_NEAR(s.x_m, 0.3, 1e-9);
    EXPECT_NEAR(s.y_m, -0.04, 1e-9);
    EXPECT_NEAR(s.tilt_rad, 0, 1e-6);
  }
}

TEST(TagHeading, RobotTurningCounterClockwiseIncreasesTheHeading) {
  // Paper §3.4's Δθ is the robot's turn: the sign must follow the robot, not the tag.
  wheels::CameraMount m;
  const double a = wheels::sightTag(tagSeenAt(m, 0.0, 0.3, 0), m).heading_rad;
  const double b = wheels::sightTag(tagSeenAt(m, 0.1, 0.3, 0), m).heading_rad;
  EXPECT_NEAR(b - a, 0.1, 1e-9);
}

TEST(TagHeading, OutliersAreRejectedNotAveraged) {
  std::vector<wheels::TagSighting> s(5);
  const double hs[5] = {0.020, 0.022, 0.018, M_PI / 2, 0.021};  // one tag laid at 90°
  for (int i = 0; i < 5; ++i) {
    s[i].heading_rad = hs[i];
    s[i].distance_m = 0.3;
  }
  s.push_back(s[0]);
  s.back().tilt_rad = 0.5;  // not lying on the floor
  s.back().heading_rad = -0.4;
  const wheels::HeadingMeasurement m = wheels::measureHeading(s, wheels::HeadingOptions());
  ASSERT_TRUE(m.valid);
  EXPECT_EQ(m.inliers, 4);
  EXPECT_EQ(m.outliers, 2);
  EXPECT_NEAR(m.heading_rad, 0.02025, 1e-9);
}

TEST(TagHeading, HeadingAcrossTheWrapIsAveragedOnTheCircle) {
  std::vector<wheels::TagSighting> s(2);
  s[0].heading_rad = M_PI - 0.01;
  s[1].heading_rad = -M_PI + 0.01;
  s[0].distance_m = s[1].distance_m = 0.3;
  const wheels::HeadingMeasurement m = wheels::measureHeading(s, wheels::HeadingOptions());
  ASSERT_TRUE(m.valid);
  EXPECT_NEAR(std::abs(m.heading_rad), M_PI, 1e-9);
}

TEST(TagHeading, NoTagsIsNoMeasurement) {
  EXPECT_FALSE(wheels::measureHeading({}, wheels::HeadingOptions()).valid);
}

TEST(TagHeading, LateralOffsetFromTheTagLineWhateverTheHeading) {
  // Tags along the world's x axis (their up), the robot 0.1 m to the left of them (+y).
  for (double h : {-0.4, 0.0, 0.2}) {
    std::vector<wheels::TagSighting> s;
    for (double along : {0.3, 0.45, 0.6}) {
      const double dx = along, dy = -0.1;  // tag minus robot, world frame
      wheels::TagSighting t;
      t.x_m = std::cos(h) * dx + std::sin(h) * dy;
      t.y_m = -std::sin(h) * dx + std::cos(h) * dy;
      t.heading_rad = h;
      t.distance_m = 0.4;
      s.push_back(t);
    }
    s.push_back(s[0]);
    s.back().heading_rad = h + 1.0;  // an outlier: not averaged
    s.back().y_m += 1.0;
    const wheels::HeadingMeasurement m = wheels::measureHeading(s, wheels::HeadingOptions());
    EXPECT_NEAR(wheels::measureLateralM(s, m, wheels::HeadingOptions()), 0.1, 1e-9) << h;
  }
  EXPECT_TRUE(std::isnan(wheels::measureLateralM({}, wheels::HeadingMeasurement(), {})));
}

TEST(TagPose, FloorNormalPicksTheSolutionLyingOnTheFloor) {
  // A tag seen nearly frontally: both IPPE solutions fit; the floor normal decides.
  wheels::CameraMount m;
  m.pitch_rad = 1.2;  // looking almost straight down
  const markers::TagDetection truth = tagSeenAt(m, 0.3, 0.06, 0.0);
  const cv::Matx33d K(300, 0, 320, 0, 300, 240, 0, 0, 1);
  markers::TagDetection d = truth;
  const double h = 0.0325;
  const cv::Vec3d obj[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  for (int k = 0; k < 4; ++k) {
    const cv::Vec3d p = K * (truth.rotation * obj[k] + truth.translation_m);
    d.corners_px[k] = {p[0] / p[2], p[1] / p[2]};
  }
  markers::estimateTagPose(d, 0.065, K, m.floorUpInCamera());
  const wheels::TagSighting s = wheels::sightTag(d, m);
  EXPECT_NEAR(s.heading_rad, 0.3, 1e-3);
  EXPECT_LT(s.tilt_rad, 0.01);
}

TEST(TagDetectorOptions, BadValuesNameTheirKey) {
  markers::TagDetectorOptions o;
  o.decimate = 0.5;
  try {
    o.validate();
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("decimate"), std::string::npos);
  }
}

TEST(TagHeading, FloorRowLimitIsWhereTheFloorAtThatDepthIsImaged) {
  autocal::wheels::CameraMount mount;  // 0.105 m high, pitched down 0.26 rad
  // The optical axis meets the floor h/tan(pitch) ahead: imaged on the principal point's row.
  const double axis_m = mount.height_m / std::tan(mount.pitch_rad);
  EXPECT_NEAR(autocal::wheels::floorRowLimitPx(mount, 320, 240, 480, axis_m), 240, 1);
  // Farther floor is higher in the image, nearer floor lower; the horizon is fy·tan(pitch) above.
  EXPECT_LT(autocal::wheels::floorRowLimitPx(mount, 320, 240, 480, 0.65), 240);
  EXPECT_GT(autocal::wheels::floorRowLimitPx(mount, 320, 240, 480, 0.2), 240);
  EXPECT_NEAR(autocal::wheels::floorRowLimitPx(mount, 320, 240, 480, 1e6),
              240 - 320 * std::tan(mount.pitch_rad), 1);
  // A camera looking up: floor 1 m ahead is below the image (no row can show it).
  mount.pitch_rad = -1.0;
  EXPECT_EQ(autocal::wheels::floorRowLimitPx(mount, 320, 240, 480, 1.0), 480);
}
