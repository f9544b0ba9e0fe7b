#include "autocal_ros/tag_params.h"

namespace autocal {
namespace ros_layer {

void readTagParams(const ParamReader& p, markers::TagDetectorOptions& detector,
                   wheels::HeadingOptions& heading, wheels::CameraMount& mount) {
  p.get("tag_size_m", detector.tag_size_m);
  p.get("tag_decimate", detector.decimate);
  p.get("tag_threads", detector.threads);
  p.get("tag_refine_edges", detector.refine_edges);
  p.get("tag_max_hamming", detector.max_hamming);
  p.get("tag_min_decision_margin", detector.min_decision_margin);
  p.get("max_tag_tilt_rad", heading.max_tilt_rad);
  p.get("tag_outlier_rad", heading.outlier_rad);
  p.get("max_tag_distance_m", heading.max_distance_m);
  p.get("prefer_tag_distance_m", heading.prefer_distance_m);
  p.get("camera_height_m", mount.height_m);
  p.get("camera_pitch_rad", mount.pitch_rad);
  p.get("camera_x_m", mount.x_m);
  p.get("camera_y_m", mount.y_m);
}

}  // namespace ros_layer
}  // namespace autocal
