// The ground homography of a camera mount and back (extrinsics::homographyFromMount,
// mountFromHomography), and dt-core's pixel2ground / ground2pixel.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/extrinsics/floor_board.h"
#include "autocal/extrinsics/ground_projection.h"
#include "autocal/extrinsics/tag_mount.h"

namespace {

using namespace autocal::extrinsics;

RectifiedCamera someCamera() {
  RectifiedCamera c;
  c.P << 280.5, 0, 318.2, 0, 283.1, 241.7, 0, 0, 1;
  return c;
}

TEST(GroundProjection, MountToHomographyAndBack) {
  const RectifiedCamera cam = someCamera();
  for (const CameraMount& m : {CameraMount{0.105, 0.26, 0.0, 0.0, 0.055, 0.0},
                               CameraMount{0.09, 0.4, 0.03, -0.05, 0.07, 0.012},
                               CameraMount{0.13, 0.15, -0.02, 0.08, -0.02, -0.03}}) {
    const Eigen::Matrix3d H = homographyFromMount(m, cam);
    EXPECT_NEAR(H(2, 2), 1.0, 1e-12);
    const CameraMount back = mountFromHomography(3.7 * H, cam);  // any scale
    EXPECT_NEAR(back.height_m, m.height_m, 1e-9);
    EXPECT_NEAR(back.pitch_rad, m.pitch_rad, 1e-9);
    EXPECT_NEAR(back.roll_rad, m.roll_rad, 1e-9);
    EXPECT_NEAR(back.yaw_rad, m.yaw_rad, 1e-9);
    EXPECT_NEAR(back.x_m, m.x_m, 1e-9);
    EXPECT_NEAR(back.y_m, m.y_m, 1e-9);
    const CameraMount flipped = mountFromHomography(-H, cam);  // the sign of a scale too
    EXPECT_NEAR(flipped.height_m, m.height_m, 1e-9);
  }
}

// floorSigmaM against the ground projection itself: the pixel that shows the floor point 0.5 m
// ahead of the camera, put back on the floor through a mount moved by one small sigma at a time.
TEST(FloorSigma, MatchesHowFarEachMountErrorMovesTheFloorPointAhead) {
  const RectifiedCamera cam = someCamera();
  const CameraMount m{0.105, 0.26, 0.0, 0.0, 0.055, 0.0};
  const double d = 0.5;
  const Eigen::Vector2d point(m.x_m + d, m.y_m);
  const Eigen::Vector2d pixel = groundToPixel(homographyFromMount(m, cam), point);
  const std::vector<CameraMount> one_at_a_time{{0.001, 0, 0, 0, 0, 0},
                                               {0, 0.002, 0, 0, 0, 0},
                                               {0, 0, 0, 0.003, 0, 0},
                                               {0, 0, 0, 0, 0.001, 0},
                                               {0, 0, 0, 0, 0, 0.001}};
  double sum_sq = 0;
  CameraMount all{0, 0, 0, 0, 0, 0};
  for (const CameraMount& s : one_at_a_time) {
    CameraMount moved = m;
    moved.height_m += s.height_m;
    moved.pitch_rad += s.pitch_rad;
    moved.yaw_rad += s.yaw_rad;
    moved.x_m += s.x_m;
    moved.y_m += s.y_m;
    const double shift = (pixelToGround(homographyFromMount(moved, cam), pixel) - point).norm();
    EXPECT_NEAR(floorSigmaM(m, s, d), shift, 0.05 * shift);
    sum_sq += shift * shift;
    all.height_m += s.height_m;
    all.pitch_rad += s.pitch_rad;
    all.yaw_rad += s.yaw_rad;
    all.x_m += s.x_m;
    all.y_m += s.y_m;
  }
  EXPECT_NEAR(floorSigmaM(m, all, d), std::sqrt(sum_sq), 0.05 * std::sqrt(sum_sq));
  EXPECT_EQ(floorSigmaM(m, CameraMount{0, 0, 0, 0, 0, 0}, d), 0.0);
}

TEST(GroundProjection, ALevelCameraSeesTheFloorAheadBelowTheImageCentre) {
  // Pitched down by 0.3 rad at 0.1 m: the optical axis meets the floor 0.1/tan(0.3) ahead of the
  // camera, at the principal point.
  const RectifiedCamera cam = someCamera();
  const CameraMount m{0.1, 0.3, 0.0, 0.0, 0.05, 0.0};
  const Eigen::Matrix3d H = homographyFromMount(m, cam);
  const Eigen::Vector2d g = pixelToGround(H, {cam.P(0, 2), cam.P(1, 2)});
  EXPECT_NEAR(g.x(), 0.05 + 0.1 / std::tan(0.3), 1e-9);
  EXPECT_NEAR(g.y(), 0.0, 1e-9);
  // Left of the centre line is left in the image (smaller u).
  EXPECT_LT(groundToPixel(H, {0.4, 0.05}).x(), cam.P(0, 2));
  const Eigen::Vector2d p = groundToPixel(H, {0.3, -0.07});
  EXPECT_NEAR((pixelToGround(H, p) - Eigen::Vector2d(0.3, -0.07)).norm(), 0.0, 1e-12);
  // Yawed left, the floor straight ahead appears right of the centre.
  const Eigen::Matrix3d yawed = homographyFromMount({0.1, 0.3, 0.0, 0.1, 0.05, 0.0}, cam);
  EXPECT_GT(groundToPixel(yawed, {0.4, 0.0}).x(), cam.P(0, 2));
}

TEST(FloorGrid, DrawsItsLinesWhereTheHomographyPutsThemAndNothingBehindTheCamera) {
  const RectifiedCamera cam = someCamera();
  for (const CameraMount& m : {CameraMount{0.105, 0.26, 0.0, 0.0, 0.055, 0.0},
                               CameraMount{0.09, 0.4, 0.03, -0.05, 0.07, 0.012}}) {
    for (const double scale : {1.0, -2.0}) {  // any scale of H, either sign
      const Eigen::Matrix3d H = scale * homographyFromMount(m, cam);
      cv::Mat img(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
      drawFloorGrid(img, H);
      const auto at = [&](double x, double y) {
        const Eigen::Vector2d p = groundToPixel(H, {x, y});
        return img.at<cv::Vec3b>(static_cast<int>(std::lround(p.y())),
                                 static_cast<int>(std::lround(p.x())));
      };
      // On the centre line (yellow), on a cross line (green), between the lines (nothing).
      EXPECT_GT(at(0.325, 0.0)[2], 100);
      EXPECT_LT(at(0.325, 0.0)[0], 60);
      EXPECT_GT(at(0.30, 0.025)[1], 100);
      EXPECT_EQ(at(0.325, 0.025), cv::Vec3b(0, 0, 0));
      // The grid lies inside the image rows the floor 0.1-0.6 m ahead covers.
      double top = 1e9;
      for (const double y : {-0.3, 0.0, 0.3}) top = std::min(top, groundToPixel(H, {0.6, y}).y());
      for (int v = 0; v < static_cast<int>(top) - 2; ++v) {
        const cv::Mat row = img.row(v);
        ASSERT_EQ(cv::countNonZero(row.reshape(1)), 0) << "row " << v << " above the grid";
      }
    }
  }
  // A camera looking almost level: a grid reaching behind it draws only the part in front.
  const Eigen::Matrix3d level = homographyFromMount({0.1, 0.05, 0.0, 0.0, 0.3, 0.0}, cam);
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  drawFloorGrid(img, level, {0.0, 2.0, 0.3, 0.1});
  cv::Mat gray;
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::countNonZero(gray.rowRange(0, 240)), 0);  // nothing above the horizon
  EXPECT_GT(cv::countNonZero(gray.rowRange(240, 480)), 0);
  cv::Mat gray_image(480, 640, CV_8UC1);
  EXPECT_THROW(drawFloorGrid(gray_image, level), autocal::InputError);
}

TEST(GroundProjection, SingularInputIsAClearError) {
  EXPECT_THROW(mountFromHomography(Eigen::Matrix3d::Zero(), someCamera()),
               autocal::CalibrationError);
  // The floor through the optical centre.
  EXPECT_THROW(homographyFromMount({0.0, 0.3, 0.0, 0.0, 0.05, 0.0}, someCamera()),
               autocal::CalibrationError);
}

}  // namespace
