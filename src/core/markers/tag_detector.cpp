#include "autocal/markers/tag_detector.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"

namespace autocal {
namespace markers {

void TagDetectorOptions::validate() const {
  if (family != "tag36h11")
    throw ConfigError("family: only tag36h11 is supported, not '" + family + "'");
  if (!(decimate >= 1.0 && decimate <= 8.0)) throw ConfigError("decimate: must be within [1, 8]");
  if (!(blur_sigma_px >= 0.0 && blur_sigma_px <= 5.0))
    throw ConfigError("blur_sigma_px: must be within [0, 5]");
  if (threads < 1 || threads > 64) throw ConfigError("threads: must be within [1, 64]");
  if (max_hamming < 0 || max_hamming > 2) throw ConfigError("max_hamming: must be 0, 1 or 2");
  if (!(min_decision_margin >= 0.0)) throw ConfigError("min_decision_margin: must be >= 0");
  if (!(tag_size_m > 0.0 && tag_size_m < 10.0)) throw ConfigError("tag_size_m: must be > 0 [m]");
  if (min_row_px < 0) throw ConfigError("min_row_px: must be >= 0 [px]");
}

Undistorter::Undistorter(const CameraIntrinsics& intrinsics) : intrinsics_(intrinsics) {
  if (!(intrinsics.fx > 0 && intrinsics.fy > 0) || intrinsics.width <= 0 ||
      intrinsics.height <= 0) {
    throw ConfigError("intrinsics: fx, fy, width and height must be positive");
  }
  const cv::Mat K(intrinsics.cameraMatrix());
  const cv::Mat D(intrinsics.distortion_coefficients, true);
  if (intrinsics.distortion_model == DistortionModel::kEquidistant) {
    cv::fisheye::initUndistortRectifyMap(K, D, cv::Matx33d::eye(), K, intrinsics.imageSize(),
                                         CV_16SC2, map1_, map2_);
  } else {
    cv::initUndistortRectifyMap(K, D, cv::Matx33d::eye(), K, intrinsics.imageSize(), CV_16SC2,
                                map1_, map2_);
  }
}

cv::Mat Undistorter::undistort(const cv::Mat& image) const {
  if (image.empty()) throw InputError("empty image");
  if (image.size() != intrinsics_.imageSize()) {
    throw InputError("image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                     " but the intrinsics are for " + std::to_string(intrinsics_.width) + "x" +
                     std::to_string(intrinsics_.height));
  }
  cv::Mat out;
  cv::remap(image, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

struct TagDetector::Impl {
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
};

TagDetector::TagDetector(const TagDetectorOptions& options, const CameraIntrinsics& intrinsics)
    : options_(options), undistorter_(intrinsics), impl_(new Impl) {
  options_.validate();
  impl_->family = tag36h11_create();
  impl_->detector = apriltag_detector_create();
  apriltag_detector_add_family_bits(impl_->detector, impl_->family, options_.max_hamming);
  impl_->detector->quad_decimate = static_cast<float>(options_.decimate);
  impl_->detector->quad_sigma = static_cast<float>(options_.blur_sigma_px);
  impl_->detector->nthreads = options_.threads;
  impl_->detector->refine_edges = options_.refine_edges ? 1 : 0;
}

TagDetector::~TagDetector() {
  if (impl_->detector) apriltag_detector_destroy(impl_->detector);
  if (impl_->family) tag36h11_destroy(impl_->family);
}

void TagDetector::setFloorNormal(const cv::Vec3d& up_in_camera) {
  const double n = cv::norm(up_in_camera);
  have_floor_normal_ = n > 0;
  floor_up_ = have_floor_normal_ ? up_in_camera / n : cv::Vec3d(0, 0, 0);
}

std::vector<TagDetection> TagDetector::detect(const cv::Mat& image) const {
  return detectUndistorted(undistorter_.undistort(image));
}

std::vector<TagDetection> TagDetector::detectUndistorted(const cv::Mat& undistorted) const {
  if (undistorted.empty()) throw InputError("empty image");
  cv::Mat gray;
  if (undistorted.channels() == 3) {
    cv::cvtColor(undistorted, gray, cv::COLOR_BGR2GRAY);
  } else if (undistorted.channels() == 1) {
    gray = undistorted;
  } else {
    throw InputError("image must be grey or BGR, has " + std::to_string(undistorted.channels()) +
                     " channels");
  }
  if (gray.depth() != CV_8U) throw InputError("image must have 8-bit channels");
  // Only the rows from min_row_px down (a view, no copy); corners are shifted back below.
  const int row0 = std::min(options_.min_row_px, std::max(0, gray.rows - 16));
  if (row0 > 0) gray = gray.rowRange(row0, gray.rows);
  if (!gray.isContinuous()) gray = gray.clone();
  image_u8_t im{gray.cols, gray.rows, static_cast<int32_t>(gray.step), gray.data};
  zarray_t* found = apriltag_detector_detect(impl_->detector, &im);
  std::vector<TagDetection> result;
  const cv::Matx33d K = undistorter_.intrinsics().cameraMatrix();
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, i, &det);
    if (det->hamming > options_.max_hamming || det->decision_margin < options_.min_decision_margin)
      continue;
    TagDetection d;
    d.id = det->id;
    d.family = options_.family;
    d.hamming = det->hamming;
    d.decision_margin = det->decision_margin;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) d.homography(r, c) = MATD_EL(det->H, r, c);
    // libapriltag puts the first pixel's centre at (0.5, 0.5), OpenCV and the camera matrix at
    // (0, 0): its corners are half a pixel right of and below OpenCV's (a tag rendered at known
    // corners: kLibapriltagPixelCentre). Back to OpenCV's pixels, in the whole image: u −= 0.5,
    // v += row0 − 0.5 (the homography's rows: u·w = row0 − 0.5·row2, v·w = row1 + (row0 −
    // 0.5)·row2).
    const double du = -kLibapriltagPixelCentre, dv = row0 - kLibapriltagPixelCentre;
    for (int c = 0; c < 3; ++c) {
      d.homography(0, c) += du * d.homography(2, c);
      d.homography(1, c) += dv * d.homography(2, c);
    }
    d.center_px = {det->c[0] + du, det->c[1] + dv};
    for (int k = 0; k < 4; ++k) d.corners_px[k] = {det->p[k][0] + du, det->p[k][1] + dv};
    estimateTagPose(d, options_.tag_size_m, K, have_floor_normal_ ? floor_up_ : cv::Vec3d(0, 0, 0));
    result.push_back(d);
  }
  apriltag_detections_destroy(found);
  return result;
}

void estimateTagPose(TagDetection& detection, double tag_size_m, const cv::Matx33d& K,
                     const cv::Vec3d& floor_up) {
  // libapriltag's tag frame: x to the tag's right, y down, z into the tag; corners lb, rb, rt, lt.
  const double h = 0.5 * tag_size_m;
  const std::vector<cv::Point3d> object{{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  const std::vector<cv::Point2d> pixels(detection.corners_px.begin(), detection.corners_px.end());
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat errors;
  const int n = cv::solvePnPGeneric(object, pixels, K, cv::noArray(), rvecs, tvecs, false,
                                    cv::SOLVEPNP_IPPE_SQUARE, cv::noArray(), cv::noArray(), errors);
  if (n <= 0) {
    detection.pose_error = std::numeric_limits<double>::infinity();
    return;
  }
  int best = 0;
  if (cv::norm(floor_up) > 0 && n > 1) {
    // The tag's z axis points into the floor: the solution whose z is closest to −up wins.
    double best_score = -2;
    for (int i = 0; i < n; ++i) {
      cv::Matx33d R;
      cv::Rodrigues(rvecs[i], R);
      const cv::Vec3d z(R(0, 2), R(1, 2), R(2, 2));
      const double score = -z.dot(floor_up);
      if (score > best_score) {
        best_score = score;
        best = i;
      }
    }
  }  // else: solvePnPGeneric sorts by reprojection error, the first is the best fit
  cv::Matx33d R;
  cv::Rodrigues(rvecs[best], R);
  detection.rotation = R;
  detection.translation_m =
      cv::Vec3d(tvecs[best].at<double>(0), tvecs[best].at<double>(1), tvecs[best].at<double>(2));
  detection.pose_error = errors.empty() ? 0.0 : errors.at<double>(best);
}

}  // namespace markers
}  // namespace autocal
