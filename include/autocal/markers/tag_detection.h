// One AprilTag detection as the core sees it (the fields of Duckietown's AprilTagDetection).
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>

namespace autocal {
namespace markers {

struct TagDetection {
  int id = -1;
  std::string family = "tag36h11";
  int hamming = 0;                              ///< bits corrected
  double decision_margin = 0;                   ///< libapriltag's confidence
  cv::Matx33d homography = cv::Matx33d::eye();  ///< tag plane → image
  cv::Point2d center_px;
  std::array<cv::Point2d, 4> corners_px{};  ///< libapriltag's order
  /// Pose of the tag in the camera's optical frame: x = R·x_tag + t.
  cv::Matx33d rotation = cv::Matx33d::eye();
  cv::Vec3d translation_m{0, 0, 0};
  double pose_error = 0;  ///< object-space error of the pose fit
};

}  // namespace markers
}  // namespace autocal
