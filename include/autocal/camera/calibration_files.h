// The files a camera calibration writes, the same for the offline tool and the robot's node: the
// camera_info YAML (its text is made by the ROS layer, camera_calibration_parsers) and, beside it,
// the audit folder `<stem>_views/` with the views used (lossless images, corners, per-view RMS),
// so that a result can be audited and recomputed.
#pragma once

#include <functional>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/camera/calibration.h"
#include "autocal/camera/view_selection.h"
#include "autocal/stage.h"

namespace autocal {
namespace camera {

/// `<calibration_root>/camera_intrinsic/<veh>.yaml`, the robot's intrinsics file.
std::string cameraIntrinsicsPath(const std::string& calibration_root, const std::string& veh);

/// A calibration's DONE figures: fx, fy, cx, cy, k1, k2, rms_px, views.
Figures calibrationFigures(const CalibrationResult& result);

/// The text of a camera_info YAML file for `intrinsics` named `camera_name` (the nodes give
/// camera_calibration_parsers' writer: the file must read back in ROS as Duckietown's does).
using CameraInfoFormat =
    std::function<std::string(const CameraIntrinsics& intrinsics, const std::string& camera_name)>;

/// The camera stage's file, live or replayed: writes cameraIntrinsicsPath(output) formatted by
/// `format`, with its audit folder (writeCameraCalibration); the result's file, figures
/// (calibrationFigures) and log line.
StageResult writeCameraStageFile(const StageOutput& output, const CameraInfoFormat& format,
                                 const BoardSpec& board, const CalibrationResult& result,
                                 const std::vector<CalibrationView>& views,
                                 const std::map<int, cv::Mat>& frames);

/// `<dir>/<stem>_views` for `<dir>/<stem>.yaml`.
std::string viewsDirFor(const std::string& yaml_path);

/// The audit folder's index: board, image, model, RMS and, for every used view, its image file,
/// source, RMS and corners [px] at full precision.
std::string viewsYaml(const BoardSpec& board, const CalibrationResult& result,
                      const std::vector<CalibrationView>& views, const std::string& written_for);

/// Writes the YAML and its audit folder as one: the folder is built complete under a temporary
/// name, then swapped in, then the YAML is written atomically. The previous YAML is kept as
/// `<yaml>.prev` and the previous folder as `<stem>_views.prev`, and the two `.prev` always
/// belong together (a folder without its YAML is not kept). No stale `view_NNN.png` of an earlier
/// run survives. `frames` maps CalibrationView::frame_index to the frame. Throws IoError; on
/// failure the previous YAML and folder are left (or put back) in place.
void writeCameraCalibration(const std::string& yaml_path, const std::string& yaml_text,
                            const BoardSpec& board, const CalibrationResult& result,
                            const std::vector<CalibrationView>& views,
                            const std::map<int, cv::Mat>& frames);

}  // namespace camera
}  // namespace autocal
