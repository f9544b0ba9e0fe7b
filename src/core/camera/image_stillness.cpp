// Whether the camera stands still, from two frames (see image_stillness.h).
#include "autocal/camera/image_stillness.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "autocal/camera/chessboard.h"
#include "autocal/errors.h"

namespace autocal {
namespace camera {

void ImageStillnessOptions::validate() const {
  checkConfig(std::isfinite(max_speed_px_s) && max_speed_px_s >= 0, "max_image_speed_px_s",
              "must be >= 0 [px/s] (0: off)");
  checkConfig(downsample >= 1 && downsample <= 8, "image_stillness_downsample",
              "must be within 1..8");
  checkConfig(std::isfinite(min_response) && min_response >= 0 && min_response < 1,
              "image_stillness_min_response", "must be within [0, 1)");
  checkConfig(std::isfinite(min_gradient) && min_gradient > 0, "image_stillness_min_gradient",
              "must be > 0 [grey levels²/px²]");
}

ImageStillness::ImageStillness(const ImageStillnessOptions& options) : options_(options) {
  options_.validate();
}

void ImageStillness::reset() {
  previous_.release();
  last_speed_px_s_ = -1;
}

namespace {

/// The shift of `b` against `a` (b(x) = a(x − d)) by one Gauss-Newton step of Lucas and Kanade's
/// method over the whole image, accurate below a pixel and unbiased where phase correlation's
/// sub-pixel peak is not; false when the image has too little texture in some direction.
bool smallShift(const cv::Mat& a, const cv::Mat& b, double min_gradient, cv::Point2d* d) {
  cv::Mat mean = 0.5 * (a + b), gx, gy;
  cv::Sobel(mean, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(mean, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  const cv::Mat it = b - a;
  const double xx = gx.dot(gx), xy = gx.dot(gy), yy = gy.dot(gy);
  const double rx = gx.dot(it), ry = gy.dot(it);
  const double det = xx * yy - xy * xy, n = static_cast<double>(a.total());
  // The smaller eigenvalue of the gradients' matrix, per pixel [grey²/px²].
  const double lambda_min = 0.5 * (xx + yy - std::sqrt((xx - yy) * (xx - yy) + 4 * xy * xy)) / n;
  if (!(det > 0) || lambda_min < min_gradient) return false;
  // it = −g·d: d = −A⁻¹ r.
  d->x = -(yy * rx - xy * ry) / det;
  d->y = -(xx * ry - xy * rx) / det;
  return true;
}

}  // namespace

bool ImageStillness::add(double stamp_s, const cv::Mat& image) {
  if (!enabled()) return true;
  cv::Mat small;
  cv::resize(toGray(image), small, cv::Size(), 1.0 / options_.downsample,
             1.0 / options_.downsample, cv::INTER_AREA);
  small.convertTo(small, CV_32F);
  // Sobel's gradient is right for the image's low frequencies only: without the blur, the shift of
  // a scene with fine texture comes out about a quarter too large.
  cv::GaussianBlur(small, small, cv::Size(), 1.5);
  if (window_.size() != small.size()) cv::createHanningWindow(window_, small.size(), CV_32F);
  const bool comparable = !previous_.empty() && previous_.size() == small.size() &&
                          stamp_s > previous_s_;
  bool still = false;
  last_speed_px_s_ = -1;
  if (comparable) {
    // Phase correlation first: it finds a shift of any size, to about a tenth of a pixel. Below a
    // pixel (full resolution), the gradient step measures it to hundredths.
    double response = 0;
    cv::Point2d shift = cv::phaseCorrelate(previous_, small, window_, &response);
    bool measured = response >= options_.min_response;
    if (measured && std::hypot(shift.x, shift.y) * options_.downsample < 1.0)
      measured = smallShift(previous_, small, options_.min_gradient, &shift);
    if (measured) {
      last_speed_px_s_ =
          std::hypot(shift.x, shift.y) * options_.downsample / (stamp_s - previous_s_);
      still = last_speed_px_s_ <= options_.max_speed_px_s;
    }
  }
  previous_ = small;
  previous_s_ = stamp_s;
  return still;
}

}  // namespace camera
}  // namespace autocal
