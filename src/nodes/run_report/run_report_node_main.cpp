// rosrun autocal run_report_node — see run_report_node.h and doc/nodes/run_report_node.md.
#include "autocal_ros/node_runtime.h"
#include "run_report_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "run_report_node";
  options.phase = "run";
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::report::RunReportNode node(nh, pnh);
                                       node.run();
                                     });
}
