// rosrun autocal validate_straight — see validate_straight_node.h and
// doc/nodes/validate_straight.md.
#include "autocal_ros/node_runtime.h"
#include "validate_straight_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "validate_straight";
  options.phase = "validate";
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::wheels::ValidateStraightNode node(nh, pnh);
                                       node.run();
                                     });
}
