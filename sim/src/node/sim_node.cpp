#include "sim_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/package.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Range.h>
#include <tf2_ros/transform_broadcaster.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
#include "autocal/sim/scene.h"

namespace autocal {
namespace sim {

namespace {

template <typename T>
T param(const ros::NodeHandle& pnh, const std::string& name, const T& fallback) {
  T value;
  pnh.param<T>(name, value, fallback);
  return value;
}

sensor_msgs::CameraInfo cameraInfo(const Intrinsics& in) {
  sensor_msgs::CameraInfo info;
  info.width = static_cast<uint32_t>(in.width);
  info.height = static_cast<uint32_t>(in.height);
  info.distortion_model = distortionModelName(in.distortion_model);
  info.D = in.distortion_coefficients;
  info.K = {in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {in.fx, 0, in.cx, 0, 0, in.fy, in.cy, 0, 0, 0, 1, 0};
  return info;
}

geometry_msgs::Quaternion yawQuaternion(double yaw) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

}  // namespace

SimNode::SimNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), camera_rng_(0), range_rng_(0) {
  const std::string package = ros::package::getPath("autocal");
  options_.robot_config = param<std::string>(pnh_, "robot_config", package + "/sim/config/robot.yaml");
  options_.world_config = param<std::string>(pnh_, "world_config", package + "/sim/config/world.yaml");
  options_.real_time_factor = param(pnh_, "real_time_factor", options_.real_time_factor);
  options_.seed = param(pnh_, "seed", options_.seed);
  options_.physics_rate_hz = param(pnh_, "physics_rate_hz", options_.physics_rate_hz);
  options_.clock_rate_hz = param(pnh_, "clock_rate_hz", options_.clock_rate_hz);
  options_.wheels_cmd_timeout_s = param(pnh_, "wheels_cmd_timeout_s", options_.wheels_cmd_timeout_s);
  options_.ground_truth_rate_hz = param(pnh_, "ground_truth_rate_hz", options_.ground_truth_rate_hz);
  options_.status_rate_hz = param(pnh_, "status_rate_hz", options_.status_rate_hz);
  options_.camera_enabled = param(pnh_, "camera_enabled", options_.camera_enabled);
  options_.max_blur_samples = param(pnh_, "max_blur_samples", options_.max_blur_samples);
  options_.world_frame = param<std::string>(pnh_, "world_frame", options_.world_frame);
  options_.duration_s = param(pnh_, "duration_s", options_.duration_s);
  std::string ns = nh_.getNamespace();
  ns.erase(0, ns.find_first_not_of('/'));
  options_.vehicle = param<std::string>(pnh_, "vehicle", ns.empty() ? "robot" : ns);

  if (!(options_.real_time_factor >= 0)) throw ConfigError("~real_time_factor must be >= 0 (0: as fast as possible)");
  if (!(options_.clock_rate_hz > 0)) throw ConfigError("~clock_rate_hz must be > 0");
  if (!(options_.wheels_cmd_timeout_s > 0)) throw ConfigError("~wheels_cmd_timeout_s must be > 0");
  if (!(options_.ground_truth_rate_hz > 0)) throw ConfigError("~ground_truth_rate_hz must be > 0");
  if (!(options_.status_rate_hz > 0)) throw ConfigError("~status_rate_hz must be > 0");
  if (options_.max_blur_samples < 1 || options_.max_blur_samples > 64) throw ConfigError("~max_blur_samples must be 1..64");
  if (options_.seed < 0) throw ConfigError("~seed must be >= 0");

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
  base_frame_ = v + "/base_link";
  ground_truth_frame_ = v + "/ground_truth/base_link";

  clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  left_tick_pub_ = nh_.advertise<dtmsg::WheelEncoderStamped>("left_wheel_encoder_node/tick", 10);
  right_tick_pub_ = nh_.advertise<dtmsg::WheelEncoderStamped>("right_wheel_encoder_node/tick", 10);
  range_pub_ = nh_.advertise<sensor_msgs::Range>("front_center_tof_driver_node/range", 10);
  compressed_pub_ = nh_.advertise<sensor_msgs::CompressedImage>("camera_node/image/compressed", 5);
  image_pub_ = nh_.advertise<sensor_msgs::Image>("camera_node/image/raw", 5);
  camera_info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_node/camera_info", 5);
  ground_truth_pub_ = nh_.advertise<nav_msgs::Odometry>("sim/ground_truth", 10);
  status_pub_ = nh_.advertise<CalibrationStatus>("sim/status", 1, true);
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  wheels_cmd_sub_ = nh_.subscribe("wheels_driver_node/wheels_cmd", 10, &SimNode::onWheelsCmd, this);

  ROS_INFO_STREAM("sim: robot " << options_.robot_config << ", world " << options_.world_config
                                << ", seed " << options_.seed << ", real_time_factor "
                                << options_.real_time_factor << ", physics " << options_.physics_rate_hz
                                << " Hz, camera " << (options_.camera_enabled ? "on" : "off"));
}

SimNode::~SimNode() = default;

void SimNode::onWheelsCmd(const dtmsg::WheelsCmdStamped::ConstPtr& msg) {
  double left = msg->vel_left, right = msg->vel_right;
  if (!std::isfinite(left) || !std::isfinite(right)) {
    ROS_WARN_THROTTLE(1.0, "sim: dropped a wheels_cmd with a non-finite duty (%f, %f)", left, right);
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
}

void SimNode::publishClock() {
  rosgraph_msgs::Clock clock;
  clock.clock = stamp(sim_->time_s());
  clock_pub_.publish(clock);
}

void SimNode::publishEncoders() {
  const ros::Time t = stamp(sim_->time_s());
  for (Side side : {Side::kLeft, Side::kRight}) {
    dtmsg::WheelEncoderStamped msg;
    msg.header.stamp = t;
    msg.header.frame_id = options_.vehicle + (side == Side::kLeft ? "/left_wheel_axis" : "/right_wheel_axis");
    msg.data = sim_->encoderTicks(side);
    msg.resolution = static_cast<uint16_t>(robot_.encoder_resolution);
    msg.type = dtmsg::WheelEncoderStamped::ENCODER_TYPE_INCREMENTAL;
    (side == Side::kLeft ? left_tick_pub_ : right_tick_pub_).publish(msg);
  }
}

void SimNode::publishRange() {
  const RangeSensorConfig& s = robot_.range_sensor;
  sensor_msgs::Range msg;
  msg.header.stamp = stamp(sim_->time_s());
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
  const ros::Time t = stamp(std::max(0.0, capture_s - 0.5 * exposure));  // mid-exposure
  sensor_msgs::CameraInfo info = cameraInfo(robot_.camera.nominal);
  info.header.stamp = t;
  info.header.frame_id = camera_frame_;
  camera_info_pub_.publish(info);
  if (!want_compressed && !want_raw) return;  // nobody looks: skip the rendering

  const cv::Mat image = renderer_->render(sim_->exposurePoses(capture_s, options_.max_blur_samples), camera_rng_);

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
  odom.header.stamp = stamp(sim_->time_s());
  odom.header.frame_id = options_.world_frame;
  odom.child_frame_id = ground_truth_frame_;
  odom.pose.pose.position.x = p.x_m;
  odom.pose.pose.position.y = p.y_m;
  odom.pose.pose.orientation = yawQuaternion(p.yaw_rad);
  odom.twist.twist.linear.x = sim_->forwardSpeed();
  odom.twist.twist.angular.z = sim_->yawRate();
  ground_truth_pub_.publish(odom);
  geometry_msgs::TransformStamped tf;
  tf.header = odom.header;
  tf.child_frame_id = ground_truth_frame_;
  tf.transform.translation.x = p.x_m;
  tf.transform.translation.y = p.y_m;
  tf.transform.rotation = odom.pose.pose.orientation;
  tf_->sendTransform(tf);
}

void SimNode::publishStatus(double achieved_rtf) {
  CalibrationStatus status;
  status.header.stamp = stamp(sim_->time_s());
  status.phase = "sim";
  status.state = CalibrationStatus::STATE_RUNNING;
  status.progress = options_.duration_s > 0 ? static_cast<float>(sim_->time_s() / options_.duration_s) : -1.0f;
  char text[160];
  std::snprintf(text, sizeof(text), "simulating: %.1f s, real-time factor %.2f%s", sim_->time_s(), achieved_rtf,
                watchdog_stopped_ ? ", wheels stopped (no wheels_cmd)" : "");
  status.text = text;
  status.figure_names = {"sim_time_s", "real_time_factor", "x_m", "y_m", "yaw_rad"};
  const Pose2 p = sim_->pose();
  status.figure_values = {sim_->time_s(), achieved_rtf, p.x_m, p.y_m, p.yaw_rad};
  status_pub_.publish(status);
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
  const ros::WallTime wall_start = ros::WallTime::now();
  double rtf_sim_mark = 0, achieved_rtf = 0;
  ros::WallTime rtf_mark = wall_start;
  publishClock();
  publishStatus(0.0);
  while (ros::ok()) {
    sim_->step();
    const double t = sim_->time_s();
    if (due(clock, t)) publishClock();
    if (!watchdog_stopped_ && t - last_cmd_s_ > options_.wheels_cmd_timeout_s) {
      sim_->setDuty(0.0, 0.0);
      watchdog_stopped_ = true;
      ROS_WARN_THROTTLE(5.0, "sim: no wheels_cmd for %.2f s: wheels stopped", options_.wheels_cmd_timeout_s);
    }
    if (due(encoders, t)) publishEncoders();
    if (due(range, t)) publishRange();
    if (due(truth, t)) publishGroundTruth();
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
      const ros::WallTime target = wall_start + ros::WallDuration(t / options_.real_time_factor);
      const ros::WallTime now = ros::WallTime::now();
      if (target > now) (target - now).sleep();
    }
  }
  sim_->setDuty(0.0, 0.0);
}

}  // namespace sim
}  // namespace autocal
