// rosrun autocal kinematics_node — see kinematics_node.h and doc/nodes/kinematics_node.md.
#include "autocal_ros/node_runtime.h"
#include "kinematics_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "kinematics_node";
  options.phase = "kinematics";
  // Stopping the node is its normal end (exit 0); the wheels are stopped all the same.
  options.interrupt_is_failure = false;
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::wheels::KinematicsNode node(nh, pnh);
                                       node.run();
                                     });
}
