// The tag detector on tags drawn at known corners: its corners, centre and homography are in
// OpenCV's pixels (the first pixel's centre at (0, 0)), where the camera matrix puts a point.
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <random>

#include "autocal/markers/tag_detector.h"

using namespace autocal;
using namespace autocal::markers;

namespace {

constexpr int kSupersampling = 8;
const cv::Size kImage(640, 480);

/// A 640x480 image with tag `id`'s black square at `corners` (OpenCV's pixels: lb, rb, rt, lt of
/// libapriltag's order, i.e. the bitmap's bottom-left, bottom-right, top-right, top-left), drawn
/// kSupersampling times larger and averaged down (a camera's pixel integrates its area).
cv::Mat drawTag(int id, const std::array<cv::Point2d, 4>& corners) {
  apriltag_family_t* family = tag36h11_create();
  image_u8_t* bitmap = apriltag_to_image(family, id);
  const cv::Mat tag(bitmap->height, bitmap->width, CV_8U, bitmap->buf,
                    static_cast<size_t>(bitmap->stride));
  // The black square's edges in the bitmap's pixels (a pixel i spans i − 0.5 .. i + 0.5).
  const float lo = static_cast<float>((family->total_width - family->width_at_border) / 2) - 0.5f;
  const float hi = lo + static_cast<float>(family->width_at_border);
  const std::vector<cv::Point2f> src{{lo, hi}, {hi, hi}, {hi, lo}, {lo, lo}};
  std::vector<cv::Point2f> dst;
  const double s = kSupersampling;
  // A point at OpenCV pixel u lies at (u + 0.5)·s − 0.5 in the s times larger image.
  for (const cv::Point2d& c : corners)
    dst.emplace_back(static_cast<float>((c.x + 0.5) * s - 0.5),
                     static_cast<float>((c.y + 0.5) * s - 0.5));
  cv::Mat large, image;
  cv::warpPerspective(tag.clone(), large, cv::getPerspectiveTransform(src, dst),
                      kImage * kSupersampling, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 255);
  cv::resize(large, image, kImage, 0, 0, cv::INTER_AREA);
  // image_u8_destroy is not exported by Debian's libapriltag: what it does.
  free(bitmap->buf);
  free(bitmap);
  tag36h11_destroy(family);
  return image;
}

}  // namespace

TEST(TagDetector, CornersCentreAndHomographyAreInOpenCvPixels) {
  CameraIntrinsics pinhole;
  pinhole.setImageSize(kImage);
  pinhole.setCameraMatrix(cv::Matx33d(300, 0, 320, 0, 300, 240, 0, 0, 1));
  pinhole.distortion_coefficients.assign(5, 0.0);
  for (const int min_row_px : {0, 100}) {
    TagDetectorOptions o;
    o.min_row_px = min_row_px;
    const TagDetector detector(o, pinhole);
    std::mt19937 rng(4);
    std::uniform_real_distribution<double> u(-1, 1);
    cv::Point2d mean_error(0, 0);
    int corners = 0;
    for (int trial = 0; trial < 12; ++trial) {
      const cv::Point2d centre(320 + 200 * u(rng), 300 + 100 * u(rng));
      const double half = 30 + 10 * u(rng), angle = 0.6 * u(rng);
      std::array<cv::Point2d, 4> truth;
      const double sx[4] = {-1, 1, 1, -1}, sy[4] = {1, 1, -1, -1};
      for (int k = 0; k < 4; ++k) {
        const double x = half * sx[k] * (1 + 0.15 * u(rng)), y = half * sy[k];
        truth[k] = centre + cv::Point2d(x * std::cos(angle) - y * std::sin(angle),
                                        x * std::sin(angle) + y * std::cos(angle));
      }
      const std::vector<TagDetection> found = detector.detectUndistorted(drawTag(7, truth));
      ASSERT_EQ(found.size(), 1u) << "trial " << trial;
      const TagDetection& d = found[0];
      for (int k = 0; k < 4; ++k) {
        mean_error += d.corners_px[k] - truth[k];
        ++corners;
        EXPECT_LT(cv::norm(d.corners_px[k] - truth[k]), 0.25)
            << "trial " << trial << " corner " << k;
        // The homography takes the tag's corner (±1, ±1) to the same pixel.
        const cv::Vec3d p = d.homography * cv::Vec3d(k == 0 || k == 3 ? -1 : 1, k < 2 ? 1 : -1, 1);
        EXPECT_NEAR(p[0] / p[2], d.corners_px[k].x, 0.05);
        EXPECT_NEAR(p[1] / p[2], d.corners_px[k].y, 0.05);
      }
      const cv::Vec3d c = d.homography * cv::Vec3d(0, 0, 1);
      EXPECT_NEAR(c[0] / c[2], d.center_px.x, 0.05);
      EXPECT_NEAR(c[1] / c[2], d.center_px.y, 0.05);
    }
    mean_error /= corners;
    // Half a pixel off in either axis would move a tag 0.35 m ahead by 0.6 mm and tilt the floor
    // the tags make by 0.1 degree.
    EXPECT_LT(std::abs(mean_error.x), 0.05) << "min_row_px " << min_row_px;
    EXPECT_LT(std::abs(mean_error.y), 0.05) << "min_row_px " << min_row_px;
  }
}
