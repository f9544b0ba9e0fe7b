// camera::ImageStillness on a textured image moved by known sub-pixel amounts, with pixel noise:
// the speed it measures, and when it calls the image still.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "autocal/camera/image_stillness.h"
#include "autocal/errors.h"

namespace {

using autocal::camera::ImageStillness;
using autocal::camera::ImageStillnessOptions;

/// A 640x480 scene of 30 plane waves (wavelengths 8-60 px, random directions and phases) moved by
/// (dx, dy) px exactly (an image warp's interpolation is quantised to 1/32 px), with Gaussian
/// noise of `sigma` grey levels, as 8-bit.
struct Scene {
  explicit Scene(uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 30; ++k)
      waves.push_back({2 * M_PI * u(rng), 8 + 52 * u(rng), 2 * M_PI * u(rng)});
  }
  cv::Mat shifted(double dx, double dy, double sigma, std::mt19937_64& rng) const {
    cv::Mat out(480, 640, CV_8UC1);
    std::normal_distribution<double> noise(0.0, sigma);
    const double amplitude = 100 / std::sqrt(waves.size() / 2.0) / 2.5;
    for (int y = 0; y < out.rows; ++y) {
      for (int x = 0; x < out.cols; ++x) {
        double v = 0;
        for (const Wave& w : waves)
          v += std::cos(2 * M_PI / w.length_px *
                            ((x - dx) * std::cos(w.angle_rad) + (y - dy) * std::sin(w.angle_rad)) +
                        w.phase_rad);
        out.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(128 + amplitude * v + noise(rng));
      }
    }
    return out;
  }
  struct Wave {
    double angle_rad, length_px, phase_rad;
  };
  std::vector<Wave> waves;
};

TEST(ImageStillness, MeasuresTheImageSpeedBetweenFrames) {
  const Scene s(1);
  std::mt19937_64 rng(2);
  const double dt = 1.0 / 30;
  for (const double speed : {0.0, 1.5, 6.0, 30.0}) {  // [px/s]
    ImageStillness still{ImageStillnessOptions{}};
    EXPECT_FALSE(still.add(0.0, s.shifted(0, 0, 2.0, rng)));  // nothing to compare with yet
    EXPECT_LT(still.lastSpeedPxS(), 0);
    const bool is_still = still.add(dt, s.shifted(speed * dt, 0.3 * speed * dt, 2.0, rng));
    SCOPED_TRACE(speed);
    EXPECT_NEAR(still.lastSpeedPxS(), speed * std::hypot(1.0, 0.3), 0.1 * speed + 0.3);
    EXPECT_EQ(is_still, speed < 3.0);
  }
}

TEST(ImageStillness, ComparesOnlyFramesOfOneStop) {
  const Scene s(3);
  std::mt19937_64 rng(4);
  ImageStillness still{ImageStillnessOptions{}};
  EXPECT_FALSE(still.add(1.0, s.shifted(0, 0, 2.0, rng)));
  EXPECT_TRUE(still.add(1.1, s.shifted(0, 0, 2.0, rng)));
  still.reset();  // a new stop: the next frame has nothing to compare with
  EXPECT_FALSE(still.add(2.0, s.shifted(0, 0, 2.0, rng)));
  EXPECT_FALSE(still.add(2.0, s.shifted(0, 0, 2.0, rng)));  // the same stamp: no time passed
  EXPECT_TRUE(still.add(2.1, s.shifted(0, 0, 2.0, rng)));
}

TEST(ImageStillness, AFeaturelessImageIsNoMeasurement) {
  ImageStillness still{ImageStillnessOptions{}};
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  EXPECT_FALSE(still.add(0.0, grey));
  EXPECT_FALSE(still.add(0.1, grey));
  EXPECT_LT(still.lastSpeedPxS(), 0);
}

TEST(ImageStillness, OffEveryFrameIsStill) {
  ImageStillnessOptions o;
  o.max_speed_px_s = 0;
  ImageStillness still(o);
  EXPECT_TRUE(still.add(0.0, cv::Mat(480, 640, CV_8UC1, cv::Scalar(0))));
}

TEST(ImageStillnessOptions, ValidateNamesTheBadKey) {
  auto expectBad = [](auto change, const std::string& key) {
    ImageStillnessOptions o;
    change(o);
    try {
      o.validate();
      ADD_FAILURE() << key << " accepted";
    } catch (const autocal::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  expectBad([](ImageStillnessOptions& o) { o.max_speed_px_s = -1; }, "max_image_speed_px_s");
  expectBad([](ImageStillnessOptions& o) { o.downsample = 0; }, "image_stillness_downsample");
  expectBad([](ImageStillnessOptions& o) { o.min_response = 1; }, "image_stillness_min_response");
  expectBad([](ImageStillnessOptions& o) { o.min_gradient = 0; }, "image_stillness_min_gradient");
}

}  // namespace
