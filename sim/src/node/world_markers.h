// What RViz draws of the simulated world (README "RViz"): the world config and the robot as
// visualization_msgs markers. Pure conversions, no node: a gtest checks them against the configs.
#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "autocal/sim/config.h"

namespace autocal {
namespace sim {

/// The floor, walls, chessboards, floor tags (with their ids), lane lines (dashes as drawn) and
/// obstacles, in `world_frame`; one marker namespace each ("floor", "walls", "chessboards",
/// "floor_tags", "tag_ids", "lane_lines", "obstacles").
visualization_msgs::MarkerArray worldMarkers(const WorldConfig& world,
                                             const std::string& world_frame);

/// The robot's chassis, wheels and camera in `base_frame` (the simulator's true base_link), frame
/// locked so that RViz moves them with the TF; namespace "robot".
visualization_msgs::MarkerArray robotMarkers(const RobotConfig& robot,
                                             const std::string& base_frame);

}  // namespace sim
}  // namespace autocal
