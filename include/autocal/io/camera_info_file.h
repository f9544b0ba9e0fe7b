// The camera_info YAML of ROS (camera_calibration_parsers: `camera_intrinsic/<veh>.yaml`) read
// without ROS, for the core and for commands that need no master.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "autocal/camera_intrinsics.h"

namespace autocal {

/// The intrinsics of a camera_info YAML file: image_width, image_height, camera_matrix (3x3),
/// distortion_model and distortion_coefficients (rectification_matrix, projection_matrix and
/// camera_name are not needed and not checked; other keys are ignored, as the ROS parser does).
/// Throws ConfigError naming the file, line and key when the file is missing or malformed (no
/// size, a camera matrix that is not 3x3 with fx, fy > 0, a wrong number of coefficients).
CameraIntrinsics loadCameraInfoYaml(const std::string& path);

/// The same from the text of such a file; `file` names it in messages.
CameraIntrinsics parseCameraInfoYaml(const std::string& text, const std::string& file);

/// A camera_info YAML with the matrices of its rectified image.
struct CameraInfoFile {
  CameraIntrinsics intrinsics;
  cv::Matx33d rectification = cv::Matx33d::eye();  ///< R (the identity when absent)
  cv::Matx34d projection;                          ///< P
};

/// The whole camera_info YAML: as loadCameraInfoYaml, and rectification_matrix (3x3, optional)
/// and projection_matrix (3x4, required, with P's fx and fy > 0).
CameraInfoFile loadCameraInfoFile(const std::string& path);

}  // namespace autocal
