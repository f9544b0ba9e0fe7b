// rosrun autocal lane_refinement_node — see lane_refinement_node.h and
// doc/nodes/lane_refinement_node.md.
#include "autocal_ros/node_runtime.h"
#include "lane_refinement_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "lane_refinement_node";
  options.phase = "lane";
  // It commands car_cmd, not the wheels: the kinematics node and the lane follower own them.
  options.commands_wheels = false;
  options.interrupt_is_failure = false;
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::wheels::LaneRefinementNode node(nh, pnh);
                                       node.run();
                                     });
}
