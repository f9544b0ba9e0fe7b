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

/// The camera stage's config as a robot runs it: the file at `path`, with the board's inner corners
/// ("7x5"; empty: the file's) and square size [m] (0: the file's) given, and the half-resolution
/// precheck off (the robot's boards are small in its image: it misses a third of them,
/// BENCHMARKS.md, and a frame is grabbed only once per step). Throws ConfigError.
CameraCalibrationConfig loadStageCameraConfig(const std::string& path,
                                              const std::string& board_inner_corners,
                                              double board_square_m);

/// Parses "9x6" (inner corners, columns x rows); throws ConfigError otherwise.
cv::Size parseBoardSize(const std::string& text);

}  // namespace camera
}  // namespace autocal
