// rosrun autocal odometry_calibration_node — see odometry_calibration_node.h and
// doc/nodes/odometry_calibration_node.md.
#include "autocal_ros/node_runtime.h"
#include "odometry_calibration_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "odometry_calibration_node";
  options.phase = "odometry";
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::odometry::OdometryCalibrationNode node(nh, pnh);
                                       node.run();
                                     });
}
