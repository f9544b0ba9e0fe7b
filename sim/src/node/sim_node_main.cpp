// rosrun autocal sim_node — the simulated robot; see sim_node.h and README "Simulator".
#include <ros/ros.h>

#include "autocal/errors.h"
#include "sim_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "sim_node");
  // Held here, not only inside the node: when the last NodeHandle goes, ROS shuts down and with it
  // the logging, so the FATAL message below would be lost.
  ros::NodeHandle nh, pnh("~");
  try {
    autocal::sim::SimNode node(nh, pnh);
    node.run();
  } catch (const autocal::Error& e) {
    ROS_FATAL_STREAM("sim_node: " << e.what());
    return 1;
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("sim_node: unexpected error: " << e.what());
    return 2;
  }
  return 0;
}
