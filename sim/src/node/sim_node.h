// The simulator's ROS node: steps the Box2D world on its own clock (/clock, with a real-time
// factor), drives the wheels from wheels_cmd (with a watchdog), and publishes what a Duckiebot
// publishes — camera (JPEG and raw, camera_info with the NOMINAL model), wheel encoders, range —
// plus the ground truth, on its own topics only; and for RViz the world as markers (latched), the
// true path (only while somebody subscribes) and the robot's start as the odom frame.
#pragma once

#include <nav_msgs/Path.h>
#include <ros/ros.h>

#include <memory>
#include <random>
#include <string>

#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"

namespace tf2_ros {
class TransformBroadcaster;
class StaticTransformBroadcaster;
}

namespace autocal {
namespace sim {

struct SimNodeOptions {
  std::string robot_config;
  std::string world_config;
  double real_time_factor = 1.0;  ///< 0: as fast as possible
  int seed = 1;
  double physics_rate_hz = 1000.0;
  double clock_rate_hz = 200.0;  ///< /clock messages per simulated second
  double wheels_cmd_timeout_s = 0.5;
  double ground_truth_rate_hz = 50.0;
  double status_rate_hz = 1.0;
  bool camera_enabled = true;
  int max_blur_samples = 8;
  std::string vehicle;  ///< frame prefix, from the namespace
  std::string world_frame = "world";
  /// Where dead reckoning starts: a static TF world_frame → odom_frame at the robot's start, so
  /// that RViz draws a believed path (run_report_node) over the true one. Default "<veh>/odom".
  std::string odom_frame;
  /// sim/true_path is republished at most this often [Hz, wall clock], while subscribed.
  double viz_rate_hz = 2.0;
  /// The true path keeps a pose when the robot moved this far or turned 0.02 rad [m].
  double path_step_m = 0.005;
  /// The true path keeps at most this many poses (the oldest go first).
  int path_max_poses = 20000;
  double duration_s = 0.0;  ///< stop after this much simulated time (0: run until shutdown)
  /// Hold simulated time at 0 until some node publishes on wheels_cmd (a controller or a test is
  /// connected): what a real_time_factor 0 run needs so that nobody misses the start.
  bool wait_for_controller = false;
  /// Lockstep with the controller [s of sim time; 0: off]: once a wheels_cmd has arrived, time
  /// does not run more than this past the last one; the simulator waits for the next (up to
  /// lockstep_wait_s of wall time, then it runs free until a command comes again: a controller
  /// that ended or died does not stall the world). At real_time_factor 0 this makes "as fast as
  /// possible" as fast as the controller keeps up, instead of a clock the controller lags behind
  /// by a varying amount (a node without a camera to wait for could fall seconds behind).
  double lockstep_s = 0.0;
  double lockstep_wait_s = 3.0;
  /// Throws ConfigError naming the bad "~key".
  void validate() const;
};

/// The node's private parameters (README "Simulator"); ~robot_config and ~world_config are
/// required. Throws ConfigError.
SimNodeOptions readSimNodeOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh);

class SimNode {
 public:
  /// Reads parameters and configs; throws autocal::Error (ConfigError) on bad ones.
  SimNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~SimNode();
  /// Runs until shutdown (or duration_s of simulated time).
  void run();

 private:
  void onWheelsCmd(const dtmsg::WheelsCmdStamped::ConstPtr& msg);
  void publishClock();
  void waitForController();
  void publishEncoders();
  void publishRange();
  void publishCamera(double capture_s);
  void publishGroundTruth();
  void publishStatus(double achieved_rtf);
  void publishVizStatic();
  void publishTruePath();

  ros::NodeHandle nh_, pnh_;
  SimNodeOptions options_;
  RobotConfig robot_;
  WorldConfig world_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<Renderer> renderer_;
  std::mt19937_64 camera_rng_, range_rng_;

  ros::Subscriber wheels_cmd_sub_;
  ros::Publisher clock_pub_, left_tick_pub_, right_tick_pub_, range_pub_, image_pub_,
      compressed_pub_, camera_info_pub_, ground_truth_pub_, world_markers_pub_, true_path_pub_;
  ros_layer::StatusPublisher status_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_tf_;
  nav_msgs::Path true_path_;
  ros::WallTime last_path_;

  double last_cmd_s_ = -1e9;
  bool watchdog_stopped_ = true;
  bool have_cmd_ = false, lockstep_released_ = false;
  std::string camera_frame_, range_frame_, ground_truth_frame_;
};

}  // namespace sim
}  // namespace autocal
