// rosrun autocal sim_node — the simulated robot; see sim_node.h and README "Simulator".
#include "autocal_ros/node_runtime.h"
#include "sim_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "sim_node";
  options.status_topic = "sim/status";
  options.phase = "sim";
  options.commands_wheels = false;        // it is the robot: its own wheels stop with it
  options.interrupt_is_failure = false;   // roslaunch ends it with SIGINT
  // A bad config fails it at once, before run_report_node (started beside it) has subscribed to
  // sim/status: the FAILED stays up long enough for the run's report to name the cause.
  options.failure_linger_s = 3.0;
  return autocal::ros_layer::runNode(argc, argv, options, [](ros::NodeHandle nh, ros::NodeHandle pnh) {
    autocal::sim::SimNode node(nh, pnh);
    node.run();
  });
}
