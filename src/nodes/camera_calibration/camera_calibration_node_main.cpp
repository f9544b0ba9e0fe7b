// rosrun autocal camera_calibration_node — see camera_calibration_node.h and
// doc/nodes/camera_calibration_node.md.
#include "autocal_ros/node_runtime.h"
#include "camera_calibration_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "camera_calibration_node";
  options.phase = "camera";
  return autocal::ros_layer::runNode(argc, argv, options,
                                     [](ros::NodeHandle nh, ros::NodeHandle pnh) {
                                       autocal::camera::CameraCalibrationNode node(nh, pnh);
                                       node.run();
                                     });
}
