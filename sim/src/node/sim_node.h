// The simulator's ROS node: steps the Box2D world on its own clock (/clock, with a real-time
// factor), drives the wheels from wheels_cmd (with a watchdog), and publishes what a Duckiebot
// publishes — camera (JPEG and raw, camera_info with the NOMINAL model), wheel encoders, range —
// plus the ground truth, on its own topics only; and for RViz the world as markers (latched), the
// true path (only while somebody subscribes) and the robot's start as the odom frame (SimRobot).
// One robot in the node's namespace, or with ~vehicles a fleet on the one clock: each robot in its
// own namespace and its own calibration area (sim_fleet.launch).
#pragma once

#include <ros/ros.h>

#include <memory>
#include <string>
#include <vector>

#include "autocal_ros/node_runtime.h"
#include "sim_robot.h"  // the robots, and tf2_ros's broadcasters declared

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
  /// that RViz draws a believed path (run_report_node) over the true one. Empty (default):
  /// "<veh>/odom" (always so in a fleet).
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
  /// A fleet: one robot per name, each in the namespace /<name> with its own copy of the world's
  /// calibration area (frame "<name>/area", `area_spacing_m` apart along the world's y axis; robots
  /// of different areas never meet). Empty: one robot in the node's namespace (~vehicle).
  std::vector<std::string> vehicles;
  /// A fleet's robot configs, one per vehicle (empty: ~robot_config for all).
  std::vector<std::string> robot_configs;
  double area_spacing_m = 6.0;
  /// Threads that render a fleet's frames due at the same instant, each robot's on one (OpenCV's
  /// parallel_for_, cv::setNumThreads; every robot's renderer and noise are its own, so the images
  /// are those of one thread). 0: OpenCV's default (one per core); 1: all on the node's thread.
  int render_threads = 0;
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
  void publishClock();
  /// Lockstep: waits while a robot's controller is behind (SimNodeOptions::lockstep_s).
  void waitForControllers();
  void publishStatus(double achieved_rtf);
  double timeS() const { return robots_.front()->simulation().time_s(); }

  ros::NodeHandle nh_, pnh_;
  SimNodeOptions options_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_tf_;
  std::vector<std::unique_ptr<SimRobot>> robots_;
  ros::Publisher clock_pub_;
  ros_layer::StatusPublisher status_;
};

}  // namespace sim
}  // namespace autocal
