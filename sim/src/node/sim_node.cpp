#include "sim_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Range.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/sim/scene.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"
#include "world_markers.h"

namespace autocal {
namespace sim {

void SimNodeOptions::validate() const {
  auto check = [](bool ok, const std::string& key, const std::string& what) {
    if (!ok) throw ConfigError("~" + key + ": " + what);
  };
  check(real_time_factor >= 0, "real_time_factor", "must be >= 0 (0: as fast as possible)");
  check(physics_rate_hz > 0, "physics_rate_hz", "must be > 0");
  check(clock_rate_hz > 0, "clock_rate_hz", "must be > 0");
  check(wheels_cmd_timeout_s > 0, "wheels_cmd_timeout_s", "must be > 0");
  check(ground_truth_rate_hz > 0, "ground_truth_rate_hz", "must be > 0");
  check(status_rate_hz > 0, "status_rate_hz", "must be > 0");
  check(max_blur_samples >= 1 && max_blur_samples <= 64, "max_blur_samples", "must be 1..64");
  check(seed >= 0, "seed", "must be >= 0");
  check(duration_s >= 0, "duration_s", "must be >= 0 (0: run until shutdown)");
  check(std::isfinite(lockstep_s) && lockstep_s >= 0, "lockstep_s", "must be >= 0 (0: off)");
  check(std::isfinite(lockstep_wait_s) && lockstep_wait_s > 0, "lockstep_wait_s", "must be > 0");
  check(std::isfinite(viz_rate_hz) && viz_rate_hz > 0, "viz_rate_hz", "must be > 0");
  check(std::isfinite(path_step_m) && path_step_m >= 0, "path_step_m", "must be >= 0");
  check(path_max_poses >= 2, "path_max_poses", "must be >= 2");
  check(robot_configs.empty() || robot_configs.size() == vehicles.size(), "robot_configs",
        "must name one robot config per vehicle (or none: ~robot_config for all)");
  for (size_t i = 0; i < vehicles.size(); ++i) {
    check(!vehicles[i].empty() && vehicles[i].find('/') == std::string::npos, "vehicles",
          "a name must be non-empty, without '/'");
    for (size_t j = 0; j < i; ++j)
      check(vehicles[j] != vehicles[i], "vehicles", "'" + vehicles[i] + "' is named twice");
  }
  check(std::isfinite(area_spacing_m) && area_spacing_m > 0, "area_spacing_m", "must be > 0");
  check(render_threads >= 0 && render_threads <= 64, "render_threads",
        "must be 0..64 (0: one per core)");
}

SimNodeOptions readSimNodeOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  SimNodeOptions o;
  const ros_layer::ParamReader p(pnh, "sim_node");
  p.require("robot_config", o.robot_config);
  p.require("world_config", o.world_config);
  p.get("real_time_factor", o.real_time_factor);
  p.get("seed", o.seed);
  p.get("physics_rate_hz", o.physics_rate_hz);
  p.get("clock_rate_hz", o.clock_rate_hz);
  p.get("wheels_cmd_timeout_s", o.wheels_cmd_timeout_s);
  p.get("ground_truth_rate_hz", o.ground_truth_rate_hz);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("camera_enabled", o.camera_enabled);
  p.get("max_blur_samples", o.max_blur_samples);
  p.get("world_frame", o.world_frame);
  p.get("duration_s", o.duration_s);
  p.get("wait_for_controller", o.wait_for_controller);
  p.get("lockstep_s", o.lockstep_s);
  p.get("lockstep_wait_s", o.lockstep_wait_s);
  std::string ns = nh.getNamespace();
  ns.erase(0, ns.find_first_not_of('/'));
  o.vehicle = ns.empty() ? "robot" : ns;
  p.get("vehicle", o.vehicle);
  p.get("odom_frame", o.odom_frame);  // empty: "<vehicle>/odom"
  p.get("viz_rate_hz", o.viz_rate_hz);
  p.get("path_step_m", o.path_step_m);
  p.get("path_max_poses", o.path_max_poses);
  std::string vehicles, robot_configs;
  p.get("vehicles", vehicles);
  p.get("robot_configs", robot_configs);
  o.vehicles = splitCommaList(vehicles);
  o.robot_configs = splitCommaList(robot_configs);
  p.get("area_spacing_m", o.area_spacing_m);
  p.get("render_threads", o.render_threads);
  if (!o.vehicles.empty()) o.odom_frame.clear();  // each robot's own: "<veh>/odom"
  o.validate();
  return o;
}

SimNode::SimNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
  options_ = readSimNodeOptions(nh_, pnh_);
  if (options_.render_threads > 0) cv::setNumThreads(options_.render_threads);
  const WorldConfig world = loadWorldConfig(options_.world_config);
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  static_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  if (options_.vehicles.empty()) {
    robots_.push_back(std::make_unique<SimRobot>(
        nh_, options_, options_.vehicle, loadRobotConfig(options_.robot_config), world,
        options_.seed, options_.world_frame, Pose2(), *tf_, *static_tf_));
  } else {
    for (size_t i = 0; i < options_.vehicles.size(); ++i) {
      const std::string& v = options_.vehicles[i];
      const std::string robot_file =
          options_.robot_configs.empty() ? options_.robot_config : options_.robot_configs[i];
      Pose2 area;
      area.y_m = static_cast<double>(i) * options_.area_spacing_m;
      // Seeds: the robot's index added to ~seed, so that no two robots share noise.
      robots_.push_back(std::make_unique<SimRobot>(
          ros::NodeHandle("/" + v), options_, v, loadRobotConfig(robot_file), world,
          options_.seed + static_cast<int>(i), v + "/area", area, *tf_, *static_tf_));
    }
  }
  clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 1000);
  status_ = ros_layer::StatusPublisher(nh_, "sim/status");
  std::string names;
  for (const auto& r : robots_) names += (names.empty() ? "" : ", ") + r->vehicle();
  ROS_INFO_STREAM("sim: " << robots_.size() << " robot(s) (" << names << "), robot "
                          << options_.robot_config << ", world " << options_.world_config
                          << ", seed " << options_.seed << ", real_time_factor "
                          << options_.real_time_factor << ", physics " << options_.physics_rate_hz
                          << " Hz, camera " << (options_.camera_enabled ? "on" : "off")
                          << ", rendering on " << cv::getNumThreads() << " thread(s)");
}

SimNode::~SimNode() = default;

void SimNode::waitForControllers() {
  // Lockstep (SimNodeOptions::lockstep_s): wait while a robot's controller is behind, each until
  // its next wheels_cmd or its release after lockstep_wait_s of wall time.
  if (options_.lockstep_s <= 0) return;
  bool waited = false;
  ros::WallTime give_up;
  for (const auto& r : robots_) {
    if (!r->behind()) continue;
    if (!waited) {
      waited = true;
      give_up = ros::WallTime::now() + ros::WallDuration(options_.lockstep_wait_s);
      publishClock();  // the controllers' timers run on this clock
    }
    const double last = r->lastCommandS();
    while (ros_layer::ok() && r->lastCommandS() == last) {
      if (ros::WallTime::now() > give_up) {
        r->release();
        ROS_INFO_THROTTLE(10.0,
                          "sim: %s: no wheels_cmd for %.2f s of wall time: running free until the "
                          "next",
                          r->vehicle().c_str(), options_.lockstep_wait_s);
        break;
      }
      ros::WallDuration(0.0005).sleep();
      ros::spinOnce();
    }
  }
}

void SimNode::publishClock() {
  rosgraph_msgs::Clock clock;
  clock.clock = ros_layer::toRosTime(timeS());
  clock_pub_.publish(clock);
}

void SimNode::publishStatus(double achieved_rtf) {
  const double t = timeS();
  const double progress = options_.duration_s > 0 ? t / options_.duration_s : -1.0;
  char text[200];
  const SimRobot& first = *robots_.front();
  std::snprintf(
      text, sizeof(text), "simulating: %.1f s, real-time factor %.2f, %zu robot(s)%s", t,
      achieved_rtf, robots_.size(),
      robots_.size() == 1 && first.watchdogStopped() ? ", wheels stopped (no wheels_cmd)" : "");
  const Pose2 p = first.simulation().pose();  // the first robot's (the only one's) pose
  status_.running("sim", progress, text,
                  {{"sim_time_s", t},
                   {"real_time_factor", achieved_rtf},
                   {"robots", static_cast<double>(robots_.size())},
                   {"x_m", p.x_m},
                   {"y_m", p.y_m},
                   {"yaw_rad", p.yaw_rad}});
}

namespace {
/// How far behind real time [wall s] the simulator may fall before it stops catching up.
constexpr double kMaxLagS = 0.1;
}  // namespace

void SimNode::run() {
  const double dt = robots_.front()->simulation().timestep_s();
  Schedule clock{1.0 / options_.clock_rate_hz, 0.0}, status{1.0 / options_.status_rate_hz, 0.0};
  double rtf_sim_mark = 0, achieved_rtf = 0;
  std::vector<SimRobot*> frames;
  publishClock();
  publishStatus(0.0);
  for (auto& r : robots_) r->publishVizStatic();
  if (options_.wait_for_controller) {
    // At real_time_factor 0 a node started beside the simulator would find it far ahead (and
    // miss the start): hold time at 0 until every robot's controller publishes on wheels_cmd.
    for (auto& r : robots_) {
      ROS_INFO("sim: holding simulated time at 0 until a node publishes on %s",
               r->wheelsCmdTopic().c_str());
      while (ros_layer::ok() && !r->hasController()) {
        publishClock();
        ros::spinOnce();
        ros::WallDuration(0.02).sleep();
      }
    }
  }
  const ros::WallTime run_start = ros::WallTime::now();
  ros::WallTime rtf_mark = run_start;
  // Real time: simulated time t is due at pace_wall + (t - pace_sim) / real_time_factor. A
  // simulator that fell behind (a machine too slow for the factor) does not catch up in a burst,
  // which no robot's clock does (a node would see minutes of simulated time pass in a second, its
  // readings not yet delivered): it starts again from where it is, slower than asked.
  ros::WallTime pace_wall = run_start;
  double pace_sim = 0;
  while (ros_layer::ok()) {
    waitForControllers();
    for (auto& r : robots_) r->step();
    const double t = timeS();
    if (clock.due(t, dt)) publishClock();
    // Frames due now: rendered at once (a fleet's each on a thread), published in robot order.
    frames.clear();
    for (auto& r : robots_) {
      if (r->publishDue()) frames.push_back(r.get());
    }
    if (frames.size() > 1) {
      cv::parallel_for_(
          cv::Range(0, static_cast<int>(frames.size())),
          [&](const cv::Range& range) {
            for (int i = range.start; i < range.end; ++i) frames[static_cast<size_t>(i)]->renderFrame();
          },
          static_cast<double>(frames.size()));
    } else {
      for (SimRobot* r : frames) r->renderFrame();
    }
    for (SimRobot* r : frames) r->publishFrame();
    if (status.due(t, dt)) {
      const ros::WallTime now = ros::WallTime::now();
      const double wall = (now - rtf_mark).toSec();
      if (wall > 0) achieved_rtf = (t - rtf_sim_mark) / wall;
      rtf_mark = now;
      rtf_sim_mark = t;
      publishStatus(achieved_rtf);
    }
    ros::spinOnce();
    if (options_.duration_s > 0 && t >= options_.duration_s) break;
    if (options_.real_time_factor > 0) {
      const ros::WallTime target =
          pace_wall + ros::WallDuration((t - pace_sim) / options_.real_time_factor);
      const ros::WallTime now = ros::WallTime::now();
      if (target > now) {
        (target - now).sleep();
      } else if ((now - target).toSec() > kMaxLagS) {
        pace_wall = now;
        pace_sim = t;
      }
    }
  }
  for (auto& r : robots_) r->stop();
}

}  // namespace sim
}  // namespace autocal
