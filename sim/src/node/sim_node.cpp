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
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
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
  check(!odom_frame.empty(), "odom_frame", "must not be empty");
  check(std::isfinite(viz_rate_hz) && viz_rate_hz > 0, "viz_rate_hz", "must be > 0");
  check(std::isfinite(path_step_m) && path_step_m >= 0, "path_step_m", "must be >= 0");
  check(path_max_poses >= 2, "path_max_poses", "must be >= 2");
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
  o.odom_frame = o.vehicle + "/odom";
  p.get("odom_frame", o.odom_frame);
  p.get("viz_rate_hz", o.viz_rate_hz);
  p.get("path_step_m", o.path_step_m);
  p.get("path_max_poses", o.path_max_poses);
  o.validate();
  return o;
}

SimNode::SimNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), camera_rng_(0), range_rng_(0) {
  options_ = readSimNodeOptions(nh_, pnh_);

  robot_ = loadRobotConfig(options_.robot_config);
  world_ = loadWorldConfig(options_.world_config);
  SimulationOptions sim_options;
  sim_options.physics_rate_hz = options_.physics_rate_hz;
  sim_ = std::make_unique<Simulation>(robot_, world_, sim_options);
  // Every random source has its own seed derived from ~seed.
  camera_rng_.seed(static_cast<uint64_t>(options_.seed) * 2 + 1);
  range_rng_.seed(static_cast<uint64_t>(options_.seed) * 2 + 2);
  if (options_.camera_enabled) {
    RenderOptions render;
    render.supersampling = robot_.camera.supersampling;
    render.noise_sigma = robot_.camera.noise_sigma;
    render.noise_seed = static_cast<uint64_t>(options_.seed);
    renderer_ = std::make_unique<Renderer>(robot_.camera, world_, render);
  }

  const std::string& v = options_.vehicle;
  camera_frame_ = v + "/camera_optical_frame";
  range_frame_ = v + "/front_center_tof_link";
  ground_truth_frame_ = v + "/ground_truth/base_link";

  // Deep queues for the small messages: at real_time_factor 0 the simulator publishes them
  // hundreds of times faster than real time, and a subscriber that lags a few milliseconds must
  // not lose them.
  const int small_queue = 1000;
  clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", small_queue);
  left_tick_pub_ =
      nh_.advertise<dtmsg::WheelEncoderStamped>("left_wheel_encoder_node/tick", small_queue);
  right_tick_pub_ =
      nh_.advertise<dtmsg::WheelEncoderStamped>("right_wheel_encoder_node/tick", small_queue);
  range_pub_ = nh_.advertise<sensor_msgs::Range>("front_center_tof_driver_node/range", small_queue);
  compressed_pub_ = nh_.advertise<sensor_msgs::CompressedImage>("camera_node/image/compressed", 5);
  image_pub_ = nh_.advertise<sensor_msgs::Image>("camera_node/image/raw", 5);
  camera_info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_node/camera_info", small_queue);
  ground_truth_pub_ = nh_.advertise<nav_msgs::Odometry>("sim/ground_truth", small_queue);
  status_ = ros_layer::StatusPublisher(nh_, "sim/status");
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  static_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  world_markers_pub_ =
      nh_.advertise<visualization_msgs::MarkerArray>("sim/world_markers", 1, /*latch=*/true);
  true_path_pub_ = nh_.advertise<nav_msgs::Path>("sim/true_path", 1);
  true_path_.header.frame_id = options_.world_frame;
  wheels_cmd_sub_ = nh_.subscribe("wheels_driver_node/wheels_cmd", 10, &SimNode::onWheelsCmd, this);

  ROS_INFO_STREAM("sim: robot " << options_.robot_config << ", world " << options_.world_config
                                << ", seed " << options_.seed << ", real_time_factor "
                                << options_.real_time_factor << ", physics "
                                << options_.physics_rate_hz << " Hz, camera "
                                << (options_.camera_enabled ? "on" : "off"));
}

SimNode::~SimNode() = default;

void SimNode::onWheelsCmd(const dtmsg::WheelsCmdStamped::ConstPtr& msg) {
  const WheelDuties duties = ros_layer::fromWheelsCmd(*msg);
  double left = duties.left, right = duties.right;
  if (!std::isfinite(left) || !std::isfinite(right)) {
    ROS_WARN_THROTTLE(1.0, "sim: dropped a wheels_cmd with a non-finite duty (%f, %f)", left,
                      right);
    return;
  }
  if (std::abs(left) > 1 || std::abs(right) > 1) {
    ROS_WARN_THROTTLE(1.0, "sim: wheels_cmd duty beyond [-1, 1] clamped (%f, %f)", left, right);
    left = std::clamp(left, -1.0, 1.0);
    right = std::clamp(right, -1.0, 1.0);
  }
  sim_->setDuty(left, right);
  last_cmd_s_ = sim_->time_s();
  watchdog_stopped_ = false;
  have_cmd_ = true;
  lockstep_released_ = false;
}

void SimNode::waitForController() {
  // Lockstep (SimNodeOptions::lockstep_s): wait for the next wheels_cmd, or release.
  if (options_.lockstep_s <= 0 || !have_cmd_ || lockstep_released_ ||
      sim_->time_s() - last_cmd_s_ <= options_.lockstep_s)
    return;
  const double last = last_cmd_s_;
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(options_.lockstep_wait_s);
  publishClock();  // the controller's timers run on this clock
  while (ros_layer::ok() && last_cmd_s_ == last) {
    if (ros::WallTime::now() > give_up) {
      lockstep_released_ = true;
      ROS_INFO_THROTTLE(10.0,
                        "sim: no wheels_cmd for %.2f s of wall time: running free until the next",
                        options_.lockstep_wait_s);
      return;
    }
    ros::WallDuration(0.0005).sleep();
    ros::spinOnce();
  }
}

void SimNode::publishClock() {
  rosgraph_msgs::Clock clock;
  clock.clock = ros_layer::toRosTime(sim_->time_s());
  clock_pub_.publish(clock);
}

void SimNode::publishEncoders() {
  for (Side side : {Side::kLeft, Side::kRight}) {
    const EncoderReading reading{sim_->time_s(), sim_->encoderTicks(side),
                                 robot_.encoder_resolution};
    const std::string frame =
        options_.vehicle + (side == Side::kLeft ? "/left_wheel_axis" : "/right_wheel_axis");
    (side == Side::kLeft ? left_tick_pub_ : right_tick_pub_)
        .publish(ros_layer::toEncoderMsg(reading, frame));
  }
}

void SimNode::publishRange() {
  const RangeSensorConfig& s = robot_.range_sensor;
  sensor_msgs::Range msg;
  msg.header.stamp = ros_layer::toRosTime(sim_->time_s());
  msg.header.frame_id = range_frame_;
  msg.radiation_type = sensor_msgs::Range::INFRARED;
  msg.field_of_view = static_cast<float>(s.field_of_view_rad);
  msg.min_range = static_cast<float>(s.min_range_m);
  msg.max_range = static_cast<float>(s.max_range_m);
  msg.range = static_cast<float>(sim_->measureRange(range_rng_));
  range_pub_.publish(msg);
}

void SimNode::publishCamera(double capture_s) {
  const bool want_compressed = compressed_pub_.getNumSubscribers() > 0;
  const bool want_raw = image_pub_.getNumSubscribers() > 0;
  const double exposure = robot_.camera.exposure_s;
  const ros::Time t = ros_layer::toRosTime(capture_s - 0.5 * exposure);  // mid-exposure
  sensor_msgs::CameraInfo info = ros_layer::toCameraInfo(robot_.camera.nominal);
  info.header.stamp = t;
  info.header.frame_id = camera_frame_;
  camera_info_pub_.publish(info);
  if (!want_compressed && !want_raw) return;  // nobody looks: skip the rendering

  const cv::Mat image =
      renderer_->render(sim_->exposurePoses(capture_s, options_.max_blur_samples), camera_rng_);

  if (want_compressed) {
    sensor_msgs::CompressedImage msg;
    msg.header.stamp = t;
    msg.header.frame_id = camera_frame_;
    msg.format = "jpeg";
    cv::imencode(".jpg", image, msg.data, {cv::IMWRITE_JPEG_QUALITY, robot_.camera.jpeg_quality});
    compressed_pub_.publish(msg);
  }
  if (want_raw) {
    sensor_msgs::Image msg;
    msg.header.stamp = t;
    msg.header.frame_id = camera_frame_;
    msg.height = static_cast<uint32_t>(image.rows);
    msg.width = static_cast<uint32_t>(image.cols);
    msg.encoding = "bgr8";
    msg.step = static_cast<uint32_t>(image.step);
    msg.data.assign(image.datastart, image.dataend);
    image_pub_.publish(msg);
  }
}

void SimNode::publishGroundTruth() {
  const Pose2 p = sim_->pose();
  nav_msgs::Odometry odom;
  odom.header.stamp = ros_layer::toRosTime(sim_->time_s());
  odom.header.frame_id = options_.world_frame;
  odom.child_frame_id = ground_truth_frame_;
  odom.pose.pose = ros_layer::toPoseMsg(p);
  odom.twist.twist.linear.x = sim_->forwardSpeed();
  odom.twist.twist.angular.z = sim_->yawRate();
  ground_truth_pub_.publish(odom);
  geometry_msgs::TransformStamped tf;
  tf.header = odom.header;
  tf.child_frame_id = ground_truth_frame_;
  tf.transform = ros_layer::toTransformMsg(p);
  tf_->sendTransform(tf);

  // The true path, thinned to a pose per path_step_m or 0.02 rad: cheap enough to keep always,
  // published only when somebody looks (publishTruePath).
  if (!true_path_.poses.empty()) {
    const Pose2 last = ros_layer::fromPoseMsg(true_path_.poses.back().pose);
    const double turned = std::abs(std::remainder(p.yaw_rad - last.yaw_rad, 2 * M_PI));
    if (std::hypot(p.x_m - last.x_m, p.y_m - last.y_m) < options_.path_step_m && turned < 0.02)
      return;
  }
  geometry_msgs::PoseStamped pose;
  pose.header = odom.header;
  pose.pose = odom.pose.pose;
  true_path_.poses.push_back(pose);
  auto& poses = true_path_.poses;
  if (poses.size() > static_cast<size_t>(options_.path_max_poses))  // a tenth at a time
    poses.erase(poses.begin(), poses.begin() + std::max<size_t>(1, poses.size() / 10));
}

void SimNode::publishVizStatic() {
  visualization_msgs::MarkerArray markers = worldMarkers(world_, options_.world_frame);
  const visualization_msgs::MarkerArray robot = robotMarkers(robot_, ground_truth_frame_);
  markers.markers.insert(markers.markers.end(), robot.markers.begin(), robot.markers.end());
  world_markers_pub_.publish(markers);
  geometry_msgs::TransformStamped start;
  start.header.stamp = ros_layer::toRosTime(sim_->time_s());
  start.header.frame_id = options_.world_frame;
  start.child_frame_id = options_.odom_frame;
  start.transform = ros_layer::toTransformMsg(world_.robot_start);
  static_tf_->sendTransform(start);
}

void SimNode::publishTruePath() {
  if (true_path_pub_.getNumSubscribers() == 0) return;
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_path_).toSec() < 1.0 / options_.viz_rate_hz) return;
  last_path_ = now;
  true_path_.header.stamp = ros_layer::toRosTime(sim_->time_s());
  true_path_pub_.publish(true_path_);
}

void SimNode::publishStatus(double achieved_rtf) {
  const double progress = options_.duration_s > 0 ? sim_->time_s() / options_.duration_s : -1.0;
  char text[160];
  std::snprintf(text, sizeof(text), "simulating: %.1f s, real-time factor %.2f%s", sim_->time_s(),
                achieved_rtf, watchdog_stopped_ ? ", wheels stopped (no wheels_cmd)" : "");
  const Pose2 p = sim_->pose();
  status_.running("sim", progress, text,
                  {{"sim_time_s", sim_->time_s()},
                   {"real_time_factor", achieved_rtf},
                   {"x_m", p.x_m},
                   {"y_m", p.y_m},
                   {"yaw_rad", p.yaw_rad}});
}

void SimNode::run() {
  const double dt = sim_->timestep_s();
  // Each output is due at multiples of its period (in simulated time).
  struct Schedule {
    double period_s;
    double next_s;
  };
  Schedule clock{1.0 / options_.clock_rate_hz, 0.0}, encoders{1.0 / robot_.encoder_rate_hz, 0.0},
      range{1.0 / robot_.range_sensor.rate_hz, 0.0}, camera{1.0 / robot_.camera.rate_hz, 0.0},
      truth{1.0 / options_.ground_truth_rate_hz, 0.0}, status{1.0 / options_.status_rate_hz, 0.0};
  auto due = [&](Schedule& s, double t) {
    if (t + 0.5 * dt < s.next_s) return false;
    s.next_s += s.period_s;
    if (s.next_s < t) s.next_s = t + s.period_s;
    return true;
  };
  double rtf_sim_mark = 0, achieved_rtf = 0;
  publishClock();
  publishStatus(0.0);
  publishVizStatic();
  if (options_.wait_for_controller) {
    // At real_time_factor 0 a node started beside the simulator would find it far ahead (and
    // miss the start): hold time at 0 until a controller publishes on wheels_cmd.
    ROS_INFO("sim: holding simulated time at 0 until a node publishes on %s",
             wheels_cmd_sub_.getTopic().c_str());
    while (ros_layer::ok() && wheels_cmd_sub_.getNumPublishers() == 0) {
      publishClock();
      ros::spinOnce();
      ros::WallDuration(0.02).sleep();
    }
  }
  const ros::WallTime run_start = ros::WallTime::now();
  ros::WallTime rtf_mark = run_start;
  while (ros_layer::ok()) {
    waitForController();
    sim_->step();
    const double t = sim_->time_s();
    if (due(clock, t)) publishClock();
    if (!watchdog_stopped_ && t - last_cmd_s_ > options_.wheels_cmd_timeout_s) {
      sim_->setDuty(0.0, 0.0);
      watchdog_stopped_ = true;
      ROS_WARN_THROTTLE(5.0, "sim: no wheels_cmd for %.2f s: wheels stopped",
                        options_.wheels_cmd_timeout_s);
    }
    if (due(encoders, t)) publishEncoders();
    if (due(range, t)) publishRange();
    if (due(truth, t)) {
      publishGroundTruth();
      publishTruePath();
    }
    if (renderer_ && due(camera, t)) publishCamera(t);
    if (due(status, t)) {
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
      const ros::WallTime target = run_start + ros::WallDuration(t / options_.real_time_factor);
      const ros::WallTime now = ros::WallTime::now();
      if (target > now) (target - now).sleep();
    }
  }
  sim_->setDuty(0.0, 0.0);
}

}  // namespace sim
}  // namespace autocal
