// camera_view_node — the camera image with detections, raw, for RViz's Image display (Debian has no
// compressed image_transport plugin; doc/calibration_run.md "Watching a run in RViz"). While
// somebody subscribes to camera_view/image it shows the camera stage's debug image (chessboard
// corners, coverage) while that comes; else the camera's frames, and each frame the wheel stage
// detected floor tags in with them drawn over (report::drawTagDetections; the frame and its
// detections are paired by stamp, whichever comes first), held a while since the stage looks at
// frames in bursts. With no subscriber it subscribes to nothing and costs nothing.
//
// Subscribes (relative to the robot's namespace, lazily): camera_calibration_node/debug/image/
// compressed, camera_node/image/compressed, apriltag_detector_node/detections. Publishes
// camera_view/image (sensor_msgs/Image, bgr8).
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>

#include <deque>
#include <vector>

#include "autocal/markers/tag_detection.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace report {

struct CameraViewNodeOptions {
  double max_rate_hz = 10.0;  ///< images published at most this often [Hz, wall clock]
  /// The camera's frames stand in for the debug image once none came for this long [s, wall]
  /// (the camera stage draws one per step, a second or two apart: no flicker between them).
  double debug_timeout_s = 5.0;
  /// After a frame with detections, frames without wait this long [s, wall].
  double overlay_hold_s = 1.0;
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
  void showWithDetections(const sensor_msgs::CompressedImage& frame);
  void publish(const sensor_msgs::CompressedImage& msg, bool draw_detections);

  static constexpr size_t kBufferedFrames = 30;  ///< 1 s of camera: the stage answers within

  ros::NodeHandle nh_, pnh_;
  CameraViewNodeOptions options_;
  ros::Publisher image_pub_;
  ros::Subscriber debug_sub_, frame_sub_, detections_sub_;
  std::deque<sensor_msgs::CompressedImage::ConstPtr> frames_;  ///< the latest, for detections
  ros::WallTime last_published_, last_debug_, last_overlay_;
  ros::Time detections_stamp_;
  std::vector<markers::TagDetection> detections_;
};

}  // namespace report
}  // namespace autocal
