// rosrun autocal wheel_calibration_node — see wheel_calibration_node.h and
// doc/nodes/wheel_calibration_node.md.
#include "autocal_ros/node_runtime.h"
#include "wheel_calibration_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "wheel_calibration_node";
  options.phase = "wheels";
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::wheels::WheelCalibrationNode node(nh, pnh);
                                       node.run();
                                     });
}
