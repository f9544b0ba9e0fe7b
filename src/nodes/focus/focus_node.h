// focus_node — the focus assistant (paper 000 §6). Before the calibration a person turns the
// camera's focus ring; this node measures the sharpness of the board in view in every frame
// (camera::FocusMeter: 2 / the width of the board's edges, 1 for a perfectly sharp edge) and shows
// it with the best value seen so far, so that the person turns through the peak and back to it
// without judging the image by eye. It never drives the wheels and writes no file.
//
// Subscribes (relative to the robot's namespace): camera_node/image/compressed (or camera_node/
// image with ~image_transport raw). Publishes camera_view/image (sensor_msgs/Image, bgr8: the frame
// with the board's outline, a bar of the sharpness and a tick at the best; for rqt_image_view or
// RViz) and focus/status (autocal/CalibrationStatus, RUNNING, phase focus/measure, figures
// sharpness, best, edge_width_px, board), with a console line at ~status_rate_hz.
// doc/nodes/focus_node.md lists the parameters.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <memory>
#include <string>

#include "autocal/camera/focus_meter.h"
#include "autocal/status_throttle.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace camera {

struct FocusNodeOptions {
  /// The board to measure: the camera stage's config, with its inner corners ("7x5"; empty: the
  /// config's) and square size [m] (0: the config's).
  std::string camera_config;
  std::string board_inner_corners;
  double board_square_m = 0;
  std::string image_transport = "compressed";
  double status_rate_hz = 2.0;  ///< status and console lines between changes [Hz]
  /// Stop (exit 0) after this long [wall s]; 0: until shutdown.
  double max_duration_s = 0;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class FocusNode {
 public:
  FocusNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Measures frames until shutdown or ~max_duration_s; throws on failure.
  void run();

 private:
  void onFrame(const ros::Time& stamp, const cv::Mat& gray);

  ros::NodeHandle nh_;
  FocusNodeOptions options_;
  std::unique_ptr<FocusMeter> meter_;
  ros_layer::StatusPublisher status_;
  StatusThrottle throttle_;
  ros::Publisher image_pub_;
  std::unique_ptr<ros_layer::FrameInput> frames_;
  std::exception_ptr error_;
};

}  // namespace camera
}  // namespace autocal
