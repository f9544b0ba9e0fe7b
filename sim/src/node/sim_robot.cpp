// One simulated robot of sim_node (see sim_robot.h).
#include "sim_robot.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
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

#include "autocal_ros/msg_conversion.h"
#include "sim_node.h"
#include "world_markers.h"

namespace autocal {
namespace sim {

bool Schedule::due(double t_s, double dt_s) {
  if (t_s + 0.5 * dt_s < next_s) return false;
  next_s += period_s;
  if (next_s < t_s) next_s = t_s + period_s;
  return true;
}

SimRobot::SimRobot(ros::NodeHandle nh, const SimNodeOptions& options, const std::string& vehicle,
                   const RobotConfig& robot, const WorldConfig& world, int seed,
                   const std::string& area_frame, const Pose2& area_offset,
                   tf2_ros::TransformBroadcaster& tf,
                   tf2_ros::StaticTransformBroadcaster& static_tf)
    : nh_(nh),
      options_(options),
      vehicle_(vehicle),
      robot_(robot),
      world_(world),
      area_frame_(area_frame),
      area_offset_(area_offset),
      tf_(tf),
      static_tf_(static_tf),
      camera_rng_(0),
      range_rng_(0),
      // Every random source has its own seed derived from the robot's seed.
      camera_link_(robot.transport.camera, static_cast<uint64_t>(seed) * 8 + 3),
      left_encoder_link_(robot.transport.encoders, static_cast<uint64_t>(seed) * 8 + 4),
      right_encoder_link_(robot.transport.encoders, static_cast<uint64_t>(seed) * 8 + 5),
      range_link_(robot.transport.range, static_cast<uint64_t>(seed) * 8 + 6),
      wheels_cmd_link_(robot.transport.wheels_cmd, static_cast<uint64_t>(seed) * 8 + 7) {
  SimulationOptions sim_options;
  sim_options.physics_rate_hz = options_.physics_rate_hz;
  sim_options.seed = static_cast<uint64_t>(seed) * 8;
  sim_ = std::make_unique<Simulation>(robot_, world_, sim_options);
  // Every random source has its own seed derived from the robot's seed.
  camera_rng_.seed(static_cast<uint64_t>(seed) * 2 + 1);
  range_rng_.seed(static_cast<uint64_t>(seed) * 2 + 2);
  if (options_.camera_enabled) {
    RenderOptions render;
    render.supersampling = robot_.camera.supersampling;
    render.noise_sigma = robot_.camera.noise_sigma;
    render.noise_seed = static_cast<uint64_t>(seed);
    renderer_ = std::make_unique<Renderer>(robot_.camera, world_, render);
  }
  encoders_.period_s = 1.0 / robot_.encoder_rate_hz;
  range_.period_s = 1.0 / robot_.range_sensor.rate_hz;
  camera_.period_s = 1.0 / robot_.camera.rate_hz;
  truth_.period_s = 1.0 / options_.ground_truth_rate_hz;

  camera_frame_ = vehicle_ + "/camera_optical_frame";
  range_frame_ = vehicle_ + "/front_center_tof_link";
  ground_truth_frame_ = vehicle_ + "/ground_truth/base_link";
  odom_frame_ = options_.odom_frame.empty() ? vehicle_ + "/odom" : options_.odom_frame;

  // Deep queues for the small messages: at real_time_factor 0 the simulator publishes them
  // hundreds of times faster than real time, and a subscriber that lags a few milliseconds must
  // not lose them.
  const int small_queue = 1000;
  left_tick_pub_ =
      nh_.advertise<dtmsg::WheelEncoderStamped>("left_wheel_encoder_node/tick", small_queue);
  right_tick_pub_ =
      nh_.advertise<dtmsg::WheelEncoderStamped>("right_wheel_encoder_node/tick", small_queue);
  range_pub_ = nh_.advertise<sensor_msgs::Range>("front_center_tof_driver_node/range", small_queue);
  compressed_pub_ = nh_.advertise<sensor_msgs::CompressedImage>("camera_node/image/compressed", 5);
  image_pub_ = nh_.advertise<sensor_msgs::Image>("camera_node/image/raw", 5);
  camera_info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_node/camera_info", small_queue);
  ground_truth_pub_ = nh_.advertise<nav_msgs::Odometry>("sim/ground_truth", small_queue);
  world_markers_pub_ =
      nh_.advertise<visualization_msgs::MarkerArray>("sim/world_markers", 1, /*latch=*/true);
  true_path_pub_ = nh_.advertise<nav_msgs::Path>("sim/true_path", 1);
  true_path_.header.frame_id = area_frame_;
  wheels_cmd_sub_ =
      nh_.subscribe("wheels_driver_node/wheels_cmd", 10, &SimRobot::onWheelsCmd, this);
}

SimRobot::~SimRobot() = default;

bool SimRobot::behind() const {
  return options_.lockstep_s > 0 && have_cmd_ && !lockstep_released_ &&
         sim_->time_s() - last_cmd_s_ > options_.lockstep_s;
}

void SimRobot::step() {
  for (const WheelDuties& d : wheels_cmd_link_.due(sim_->time_s())) sim_->setDuty(d.left, d.right);
  sim_->step();
  if (!watchdog_stopped_ && sim_->time_s() - last_cmd_s_ > options_.wheels_cmd_timeout_s) {
    sim_->setDuty(0.0, 0.0);
    watchdog_stopped_ = true;
    ROS_WARN_THROTTLE(5.0, "sim: %s: no wheels_cmd for %.2f s: wheels stopped", vehicle_.c_str(),
                      options_.wheels_cmd_timeout_s);
  }
}

bool SimRobot::publishDue() {
  const double t = sim_->time_s(), dt = sim_->timestep_s();
  if (encoders_.due(t, dt)) publishEncoders();
  if (range_.due(t, dt)) publishRange();
  if (truth_.due(t, dt)) {
    publishGroundTruth();
    publishTruePath();
  }
  const bool render = renderer_ && camera_.due(t, dt) && beginFrame(t);
  releaseDue();
  return render;
}

void SimRobot::releaseDue() {
  const double t = sim_->time_s();
  for (DelayQueue<Send>* link :
       {&left_encoder_link_, &right_encoder_link_, &range_link_, &camera_link_}) {
    for (const Send& send : link->due(t)) send();
  }
}

void SimRobot::onWheelsCmd(const dtmsg::WheelsCmdStamped::ConstPtr& msg) {
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
  wheels_cmd_link_.push(sim_->time_s(), WheelDuties{left, right});  // on its way to the motors
  last_cmd_s_ = sim_->time_s();
  watchdog_stopped_ = false;
  have_cmd_ = true;
  lockstep_released_ = false;
}

void SimRobot::publishEncoders() {
  for (Side side : {Side::kLeft, Side::kRight}) {
    const EncoderReading reading{sim_->time_s(), sim_->encoderTicks(side),
                                 robot_.encoder_resolution};
    const std::string frame =
        vehicle_ + (side == Side::kLeft ? "/left_wheel_axis" : "/right_wheel_axis");
    ros::Publisher& pub = side == Side::kLeft ? left_tick_pub_ : right_tick_pub_;
    (side == Side::kLeft ? left_encoder_link_ : right_encoder_link_)
        .push(reading.stamp_s,
              [&pub, msg = ros_layer::toEncoderMsg(reading, frame)] { pub.publish(msg); });
  }
}

void SimRobot::publishRange() {
  const RangeSensorConfig& s = robot_.range_sensor;
  sensor_msgs::Range msg;
  msg.header.stamp = ros_layer::toRosTime(sim_->time_s());
  msg.header.frame_id = range_frame_;
  msg.radiation_type = sensor_msgs::Range::INFRARED;
  msg.field_of_view = static_cast<float>(s.field_of_view_rad);
  msg.min_range = static_cast<float>(s.min_range_m);
  msg.max_range = static_cast<float>(s.max_range_m);
  msg.range = static_cast<float>(sim_->measureRange(range_rng_));
  range_link_.push(sim_->time_s(), [this, msg] { range_pub_.publish(msg); });
}

bool SimRobot::beginFrame(double capture_s) {
  frame_compressed_ = compressed_pub_.getNumSubscribers() > 0;
  frame_raw_ = image_pub_.getNumSubscribers() > 0;
  frame_capture_s_ = capture_s;
  // Mid-exposure of the middle row (with a rolling shutter the last row is read at capture_s).
  const ros::Time t = ros_layer::toRosTime(capture_s - 0.5 * robot_.camera.readout_s -
                                           0.5 * robot_.camera.exposure_s);
  sensor_msgs::CameraInfo info = ros_layer::toCameraInfo(robot_.camera.nominal);
  info.header.stamp = t;
  info.header.frame_id = camera_frame_;
  frame_info_ = info;
  frame_jpeg_.header = frame_image_.header = info.header;
  if (frame_compressed_ || frame_raw_) {
    // The lens's focus ring, turned by a person at run time (a parameter in the robot's
    // namespace; unset: where the lens is sharp).
    double ring = robot_.camera.focus_ring_sharp_turns;
    nh_.getParamCached("sim_lens/focus_ring_turns", ring);
    if (std::isfinite(ring)) {
      renderer_->setDefocusPx(robot_.camera.defocus_px_per_turn *
                              (ring - robot_.camera.focus_ring_sharp_turns));
    }
    return true;
  }
  // Nobody looks: no rendering, camera_info alone.
  camera_link_.push(capture_s, [this, info] { camera_info_pub_.publish(info); });
  return false;
}

void SimRobot::renderFrame() {
  const cv::Mat image =
      sim::renderFrame(*renderer_, *sim_, frame_capture_s_, options_.max_blur_samples, camera_rng_);
  if (frame_compressed_) {
    frame_jpeg_.format = "jpeg";
    cv::imencode(".jpg", image, frame_jpeg_.data,
                 {cv::IMWRITE_JPEG_QUALITY, robot_.camera.jpeg_quality});
  }
  if (frame_raw_) {
    frame_image_.height = static_cast<uint32_t>(image.rows);
    frame_image_.width = static_cast<uint32_t>(image.cols);
    frame_image_.encoding = "bgr8";
    frame_image_.step = static_cast<uint32_t>(image.step);
    frame_image_.data.assign(image.datastart, image.dataend);
  }
}

void SimRobot::publishFrame() {
  // The frame and its camera_info travel (and are lost) together.
  Send send = [this, info = frame_info_,
               jpeg = frame_compressed_ ? frame_jpeg_ : sensor_msgs::CompressedImage(),
               raw = frame_raw_ ? frame_image_ : sensor_msgs::Image(),
               compressed = frame_compressed_, has_raw = frame_raw_] {
    camera_info_pub_.publish(info);
    if (compressed) compressed_pub_.publish(jpeg);
    if (has_raw) image_pub_.publish(raw);
  };
  camera_link_.push(frame_capture_s_, std::move(send));
  releaseDue();
}

void SimRobot::publishGroundTruth() {
  const Pose2 p = sim_->pose();
  nav_msgs::Odometry odom;
  odom.header.stamp = ros_layer::toRosTime(sim_->time_s());
  odom.header.frame_id = area_frame_;
  odom.child_frame_id = ground_truth_frame_;
  odom.pose.pose = ros_layer::toPoseMsg(p);
  odom.twist.twist.linear.x = sim_->forwardSpeed();
  odom.twist.twist.angular.z = sim_->yawRate();
  ground_truth_pub_.publish(odom);
  geometry_msgs::TransformStamped tf;
  tf.header = odom.header;
  tf.child_frame_id = ground_truth_frame_;
  tf.transform = ros_layer::toTransformMsg(p);
  tf_.sendTransform(tf);

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

void SimRobot::publishVizStatic() {
  visualization_msgs::MarkerArray markers = worldMarkers(world_, area_frame_);
  const visualization_msgs::MarkerArray robot = robotMarkers(robot_, ground_truth_frame_);
  markers.markers.insert(markers.markers.end(), robot.markers.begin(), robot.markers.end());
  world_markers_pub_.publish(markers);
  geometry_msgs::TransformStamped start;
  start.header.stamp = ros_layer::toRosTime(sim_->time_s());
  start.header.frame_id = area_frame_;
  start.child_frame_id = odom_frame_;
  start.transform = ros_layer::toTransformMsg(world_.robot_start);
  std::vector<geometry_msgs::TransformStamped> statics{start};
  if (area_frame_ != options_.world_frame) {  // a fleet: the area in the world
    geometry_msgs::TransformStamped area = start;
    area.header.frame_id = options_.world_frame;
    area.child_frame_id = area_frame_;
    area.transform = ros_layer::toTransformMsg(area_offset_);
    statics.push_back(area);
  }
  // One broadcaster for the whole node: /tf_static is latched, and a second one in the same
  // process would replace the first's transforms for late subscribers.
  static_tf_.sendTransform(statics);
}

void SimRobot::publishTruePath() {
  if (true_path_pub_.getNumSubscribers() == 0) return;
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_path_).toSec() < 1.0 / options_.viz_rate_hz) return;
  last_path_ = now;
  true_path_.header.stamp = ros_layer::toRosTime(sim_->time_s());
  true_path_pub_.publish(true_path_);
}

}  // namespace sim
}  // namespace autocal
