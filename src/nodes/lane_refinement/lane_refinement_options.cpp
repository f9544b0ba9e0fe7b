// lane_refinement_node's private parameters: read, and checked before the robot moves.
#include <cmath>

#include "autocal_ros/params.h"
#include "autocal_ros/tag_params.h"
#include "lane_refinement_node.h"

namespace autocal {
namespace wheels {

void LaneRefinementNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkParam(!calibration_root.empty(), "calibration_root", "must not be empty");
  ros_layer::checkLength("tag_size_m", refiner.detector.tag_size_m, ranges::kTagSize);
  ros_layer::checkLength("camera_height_m", refiner.mount.height_m, ranges::kCameraHeight);
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(std::isfinite(control_rate_hz) && control_rate_hz >= 10, "control_rate_hz",
                        "must be >= 10 Hz");
  ros_layer::checkParam(std::isfinite(status_rate_hz) && status_rate_hz > 0, "status_rate_hz",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(service_wait_s) && service_wait_s >= 0, "service_wait_s",
                        "must be >= 0");
  ros_layer::checkParam(std::isfinite(trim_poll_s) && trim_poll_s > 0, "trim_poll_s",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(max_duration_s) && max_duration_s >= 0, "max_duration_s",
                        "must be >= 0");
  ros_layer::validateParams(refiner);
}

LaneRefinementNodeOptions readLaneRefinementNodeOptions(const ros::NodeHandle& nh,
                                                        const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "lane_refinement_node");
  LaneRefinementNodeOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("intrinsics_file", o.intrinsics_file);
  p.get("image_transport", o.image_transport);
  p.get("control_rate_hz", o.control_rate_hz);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("stop_after_pass", o.stop_after_pass);
  p.get("save_calibration", o.save_calibration);
  p.get("service_wait_s", o.service_wait_s);
  p.get("trim_poll_s", o.trim_poll_s);
  p.get("max_duration_s", o.max_duration_s);

  LaneRefinerOptions& r = o.refiner;
  ros_layer::readTagParams(p, r.detector, r.heading, r.mount);
  p.get("first_tag_id", r.first_tag_id);
  p.get("num_tags", r.num_tags);
  p.get("start_max_distance_m", r.start_max_distance_m);
  p.get("start_max_heading_rad", r.start_max_heading_rad);
  p.get("start_max_lateral_m", r.start_max_lateral_m);
  p.get("speed_mps", r.speed_mps);
  p.get("heading_gain_per_s", r.heading_gain_per_s);
  p.get("max_omega_radps", r.max_omega_radps);
  p.get("orient_tolerance_rad", r.orient_tolerance_rad);
  p.get("max_orient_s", r.max_orient_s);
  p.get("lateral_gain_rad_per_m", r.lateral_gain_rad_per_m);
  p.get("max_lateral_correction_rad", r.max_lateral_correction_rad);
  p.get("settle_s", r.settle_s);
  p.get("straight_m", r.straight_m);
  p.get("max_straight_deviation_rad", r.max_straight_deviation_rad);
  p.get("min_frames_per_part", r.min_frames_per_part);
  p.get("min_part_m", r.min_part_m);
  p.get("max_part_deviation", r.max_part_deviation);
  p.get("min_parts_per_pass", r.min_parts_per_pass);
  p.get("max_heading_rad", r.max_heading_rad);
  p.get("tags_lost_s", r.tags_lost_s);
  p.get("max_pass_s", r.max_pass_s);
  p.get("stable_passes", r.stable_passes);
  p.get("stable_tolerance", r.stable_tolerance);
  p.get("apply_threshold", r.apply_threshold);
  p.get("drive_to_first_tag", r.drive_to_first_tag);
  o.validate();
  return o;
}

}  // namespace wheels
}  // namespace autocal
