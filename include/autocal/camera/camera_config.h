// Options of the camera calibration, read from config/camera_calibration.yaml (every key is
// documented there with its unit and default).
#pragma once

#include <string>

#include "autocal/camera/calibration.h"
#include "autocal/camera/chessboard.h"
#include "autocal/camera/view_selection.h"

namespace autocal {
namespace camera {

struct CameraCalibrationConfig {
  BoardSpec board;  ///< the one board every part uses
  ChessboardDetectorOptions detector;
  ViewSelectionOptions selection;
  CalibrationOptions calibration;
  QualityGateOptions quality_gate;

  /// Throws ConfigError naming the first bad value.
  void validate() const;
};

/// Reads the config file; unknown keys and bad values are ConfigErrors naming file, line and key.
CameraCalibrationConfig loadCameraCalibrationConfig(const std::string& path);

/// Parses "9x6" (inner corners, columns x rows); throws ConfigError otherwise.
cv::Size parseBoardSize(const std::string& text);

}  // namespace camera
}  // namespace autocal
