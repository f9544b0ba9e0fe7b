// The one intrinsics type of autocal: what the simulator renders with (its true and nominal
// lens), what the calibration estimates and what a camera_info carries. Pinhole + distortion in
// the conventions of OpenCV and ROS camera_info (no skew).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "autocal/distortion_model.h"

namespace autocal {

struct CameraIntrinsics {
  int width = 640;                        ///< [px]
  int height = 480;                       ///< [px]
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< [px]
  DistortionModel distortion_model = DistortionModel::kPlumbBob;
  /// ROS order: plumb_bob k1 k2 p1 p2 k3; rational_polynomial k1 k2 p1 p2 k3 k4 k5 k6;
  /// equidistant k1 k2 k3 k4.
  std::vector<double> distortion_coefficients;

  cv::Size imageSize() const { return {width, height}; }
  void setImageSize(const cv::Size& size) {
    width = size.width;
    height = size.height;
  }
  /// K = [fx 0 cx; 0 fy cy; 0 0 1].
  cv::Matx33d cameraMatrix() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
  void setCameraMatrix(const cv::Matx33d& k) {
    fx = k(0, 0);
    fy = k(1, 1);
    cx = k(0, 2);
    cy = k(1, 2);
  }
};

}  // namespace autocal
