// The floor-tag parameters every node that sights tags shares (the wheel stage, the in-lane
// refinement): the detector, which tags count for the heading, and the camera mount.
// doc/nodes/wheel_calibration_node.md and doc/nodes/lane_refinement_node.md document them.
#pragma once

#include "autocal/markers/tag_detector.h"
#include "autocal/wheels/tag_heading.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace ros_layer {

/// Reads ~tag_size_m ~tag_decimate ~tag_threads ~tag_refine_edges ~tag_max_hamming
/// ~tag_min_decision_margin ~max_tag_tilt_rad ~tag_outlier_rad ~max_tag_distance_m
/// ~prefer_tag_distance_m ~camera_height_m ~camera_pitch_rad ~camera_x_m ~camera_y_m (each kept at
/// the struct's default when not set).
void readTagParams(const ParamReader& p, markers::TagDetectorOptions& detector,
                   wheels::HeadingOptions& heading, wheels::CameraMount& mount);

}  // namespace ros_layer
}  // namespace autocal
