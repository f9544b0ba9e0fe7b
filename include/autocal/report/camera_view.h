// The camera image a person watching the run sees (RViz: doc/calibration_run.md "Watching a run in
// RViz"): a frame with the floor tags the wheel stage detected in it drawn over. ROS-free;
// camera_view_node is its node.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "autocal/markers/tag_detection.h"

namespace autocal {
namespace report {

/// Draws each detection's outline (green, its first edge red: libapriltag's corner order; lines
/// 1/200 of the image's width, at least 2 px) and id onto `image` (BGR, 8 bit).
void drawTagDetections(cv::Mat& image, const std::vector<markers::TagDetection>& detections);

}  // namespace report
}  // namespace autocal
