// rosrun autocal camera_view_node — see camera_view_node.h and doc/nodes/camera_view_node.md.
#include <ros/callback_queue.h>

#include "autocal_ros/node_runtime.h"
#include "camera_view_node.h"

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "camera_view_node";
  options.status_topic = "camera_view/status";  // not a stage: never on calibration/status
  options.phase = "view";
  options.commands_wheels = false;
  options.interrupt_is_failure = false;  // roslaunch ends it with SIGINT
  return autocal::ros_layer::runNode(
      argc, argv, options, [](ros::NodeHandle nh, ros::NodeHandle pnh) {
        autocal::report::CameraViewNode node(nh, pnh);
        // Not ros::spin(): SIGINT and SIGTERM end this loop.
        while (autocal::ros_layer::ok()) {
          ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
        }
      });
}
