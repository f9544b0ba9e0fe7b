// camera_view_node — the camera image with detections, raw, for RViz's Image display (Debian has
// no compressed image_transport plugin; README "RViz"). While somebody subscribes to
// camera_view/image it shows the camera stage's debug image (chessboard corners, coverage) while
// that comes, else the camera's frames with the floor tags the wheel stage detected in them
// (report::drawTagDetections); with no subscriber it subscribes to nothing and costs nothing.
//
// Subscribes (relative to the robot's namespace, lazily): camera_calibration_node/debug/image/
// compressed, camera_node/image/compressed, apriltag_detector_node/detections. Publishes
// camera_view/image (sensor_msgs/Image, bgr8).
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>

#include <vector>

#include "autocal/markers/tag_detection.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace report {

struct CameraViewNodeOptions {
  double max_rate_hz = 10.0;  ///< images published at most this often [Hz, wall clock]
  /// The camera's frames stand in for the debug image once none came for this long [s, wall].
  double debug_timeout_s = 1.0;
  /// Detections are drawn on a frame whose stamp is within this of theirs [s].
  double max_detection_age_s = 0.1;
  void validate() const;  ///< throws ConfigError naming the bad key
};

class CameraViewNode {
 public:
  CameraViewNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onConnection();
  void onDebugImage(const sensor_msgs::CompressedImage::ConstPtr& msg);
  void onFrame(const sensor_msgs::CompressedImage::ConstPtr& msg);
  void onDetections(const dtmsg::AprilTagDetectionArray::ConstPtr& msg);
  bool due();
  void publish(const sensor_msgs::CompressedImage& msg, bool draw_detections);

  ros::NodeHandle nh_, pnh_;
  CameraViewNodeOptions options_;
  ros::Publisher image_pub_;
  ros::Subscriber debug_sub_, frame_sub_, detections_sub_;
  ros::WallTime last_published_, last_debug_;
  ros::Time detections_stamp_;
  std::vector<markers::TagDetection> detections_;
};

}  // namespace report
}  // namespace autocal
