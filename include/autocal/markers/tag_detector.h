// AprilTag detection and pose, ROS-free: libapriltag on an image undistorted with the calibrated
// intrinsics, the pose from the undistorted corners (paper 000 §3.4: a pose from raw distorted
// corners is wrong on a wide lens) and the tag size, the planar-ambiguity solution chosen by the
// floor plane.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/markers/tag_detection.h"

namespace autocal {
namespace markers {

/// Where libapriltag puts the centre of the image's first pixel, in each axis (OpenCV: 0) [px].
/// TagDetector's corners, centre and homography are in OpenCV's pixels.
constexpr double kLibapriltagPixelCentre = 0.5;

struct TagDetectorOptions {
  /// Only tag36h11 is supported (Duckietown's family).
  std::string family = "tag36h11";
  /// libapriltag's quad_decimate: detect quads on an image this many times smaller (1 = full
  /// resolution; 2 is faster but loses small tags) [1].
  double decimate = 1.0;
  /// libapriltag's quad_sigma: Gaussian blur before quad detection [px] (0 = none).
  double blur_sigma_px = 0.0;
  /// libapriltag's nthreads.
  int threads = 1;
  /// libapriltag's refine_edges: snap the quad edges to the image gradient.
  bool refine_edges = true;
  /// Detections with more corrected bits than this are dropped.
  int max_hamming = 0;
  /// Detections with a lower decision margin than this are dropped (libapriltag's confidence).
  double min_decision_margin = 20.0;
  /// Edge of the tag's black square [m] (Duckietown: 0.065).
  double tag_size_m = 0.065;
  /// Rows of the undistorted image above this one are not searched [px] (0: the whole image). A
  /// camera looking down at floor tags sees them only below the row of the floor's far limit:
  /// searching only there is faster (libapriltag's time grows with the image and its clutter).
  int min_row_px = 0;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// Undistorts images with fixed intrinsics (maps computed once): the result is the pinhole image
/// with the same camera matrix K and no distortion.
class Undistorter {
 public:
  explicit Undistorter(const CameraIntrinsics& intrinsics);
  /// Throws InputError when the image size is not the intrinsics' size.
  cv::Mat undistort(const cv::Mat& image) const;
  const CameraIntrinsics& intrinsics() const { return intrinsics_; }

 private:
  CameraIntrinsics intrinsics_;
  cv::Mat map1_, map2_;
};

/// Detects tags and estimates their poses. Not thread-safe (one libapriltag detector).
class TagDetector {
 public:
  /// Throws ConfigError on bad options or intrinsics (e.g. fx ≤ 0).
  TagDetector(const TagDetectorOptions& options, const CameraIntrinsics& intrinsics);
  ~TagDetector();
  TagDetector(const TagDetector&) = delete;
  TagDetector& operator=(const TagDetector&) = delete;

  /// Sets the expected unit normal of the floor (pointing UP, away from the floor) in the camera's
  /// optical frame. A tag seen nearly frontally has two poses that fit its corners almost equally
  /// (IPPE's planar ambiguity); with a floor normal the one whose tag plane agrees with the floor
  /// is chosen, otherwise the one with the smaller reprojection error.
  void setFloorNormal(const cv::Vec3d& up_in_camera);

  /// Detects on a BGR or grey image of the intrinsics' size (it is undistorted first). Corners and
  /// centre are in the UNDISTORTED image (camera matrix K, no distortion); poses in the optical
  /// frame (x right, y down, z forward). Throws InputError on an empty or wrong-size image.
  std::vector<TagDetection> detect(const cv::Mat& image) const;

  /// The same on an image that is already undistorted (pinhole K).
  std::vector<TagDetection> detectUndistorted(const cv::Mat& undistorted) const;

  const TagDetectorOptions& options() const { return options_; }
  const Undistorter& undistorter() const { return undistorter_; }

 private:
  struct Impl;
  TagDetectorOptions options_;
  Undistorter undistorter_;
  bool have_floor_normal_ = false;
  cv::Vec3d floor_up_{0, 0, 0};
  std::unique_ptr<Impl> impl_;
};

/// The pose of a square tag of edge `tag_size_m` from its four corners in libapriltag's order
/// (lb, rb, rt, lt) in a pinhole image with camera matrix K; among the IPPE solutions the one whose
/// tag z axis (into the tag) is closest to −floor_up when `floor_up` is non-zero, else the one with
/// the smaller reprojection error. Sets rotation, translation_m and pose_error [px, RMS].
void estimateTagPose(TagDetection& detection, double tag_size_m, const cv::Matx33d& K,
                     const cv::Vec3d& floor_up);

}  // namespace markers
}  // namespace autocal
