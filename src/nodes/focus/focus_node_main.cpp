// rosrun autocal focus_node — see focus_node.h and doc/nodes/focus_node.md.
#include "autocal_ros/node_runtime.h"
#include "focus_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "focus_node";
  options.status_topic = "focus/status";  // not a stage: never on calibration/status
  options.phase = "focus";
  options.commands_wheels = false;
  options.interrupt_is_failure = false;  // a person ends it with Ctrl-C
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::camera::FocusNode node(nh, pnh);
                                       node.run();
                                     });
}
