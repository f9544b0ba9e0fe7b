// rostest of the simulator node (run by test/sim/*.test, each selecting its cases with a gtest
// filter): every topic at its configured rate on sim time; the robot moves on wheels_cmd and the
// watchdog stops it; a bad config makes the node exit non-zero. Checked against the simulator's
// ground truth and against the config files, never against what the node says about itself.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Range.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "autocal/exit_codes.h"
#include "autocal/io/format.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::dtmsg::WheelEncoderStamped;
using autocal::dtmsg::WheelsCmdStamped;
using autocal::test::spinUntil;
using autocal::test::spinUntilSimTime;
using autocal::test::testParam;

std::string robotConfigPath() { return std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml"; }

/// Every subscriber has a publisher.
bool allConnected(const std::vector<ros::Subscriber>& subs) {
  for (const auto& sub : subs)
    if (sub.getNumPublishers() == 0) return false;
  return true;
}

/// Header stamps received per topic.
struct StampLog {
  std::map<std::string, std::vector<double>> stamps;
  template <class M>
  ros::Subscriber track(ros::NodeHandle& nh, const std::string& topic) {
    return nh.subscribe<M>(topic, 2000, [this, topic](const boost::shared_ptr<const M>& m) {
      stamps[topic].push_back(m->header.stamp.toSec());
    });
  }
  /// Messages received per second of sim time in [t0, t1).
  double rateIn(const std::string& topic, double t0_s, double t1_s) const {
    auto it = stamps.find(topic);
    if (it == stamps.end()) return 0.0;
    int n = 0;
    for (double t : it->second) n += (t >= t0_s && t < t1_s) ? 1 : 0;
    return n / (t1_s - t0_s);
  }
  /// The publication rate from the median interval between consecutive stamps in [t0, t1): a
  /// message the transport dropped (a publisher queue overflowing on a loaded machine) leaves one
  /// longer gap, not a slower rate.
  double medianRateIn(const std::string& topic, double t0_s, double t1_s) const {
    auto it = stamps.find(topic);
    if (it == stamps.end()) return 0.0;
    std::vector<double> dt;
    for (size_t i = 1; i < it->second.size(); ++i) {
      if (it->second[i - 1] >= t0_s && it->second[i] < t1_s)
        dt.push_back(it->second[i] - it->second[i - 1]);
    }
    if (dt.empty()) return 0.0;
    std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
    return 1.0 / dt[dt.size() / 2];
  }
};

TEST(SimNode, PublishesEveryTopicAtItsRateOnSimTime) {
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  ros::NodeHandle nh(testParam<std::string>("veh"));
  const double tolerance = testParam<double>("rate_tolerance");
  StampLog log;
  std::vector<ros::Subscriber> subs;
  subs.push_back(log.track<WheelEncoderStamped>(nh, "left_wheel_encoder_node/tick"));
  subs.push_back(log.track<WheelEncoderStamped>(nh, "right_wheel_encoder_node/tick"));
  subs.push_back(log.track<sensor_msgs::Range>(nh, "front_center_tof_driver_node/range"));
  subs.push_back(log.track<sensor_msgs::CameraInfo>(nh, "camera_node/camera_info"));
  subs.push_back(log.track<nav_msgs::Odometry>(nh, "sim/ground_truth"));
  std::vector<double> clock_s;
  subs.push_back(nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 5000,
      [&](const rosgraph_msgs::Clock::ConstPtr& m) { clock_s.push_back(m->clock.toSec()); }));
  sensor_msgs::CompressedImage::ConstPtr last_jpeg;
  sensor_msgs::Image::ConstPtr last_raw;
  sensor_msgs::CameraInfo::ConstPtr last_info;
  WheelEncoderStamped::ConstPtr last_tick;
  subs.push_back(nh.subscribe<sensor_msgs::CompressedImage>(
      "camera_node/image/compressed", 200, [&](const sensor_msgs::CompressedImage::ConstPtr& m) {
        log.stamps["jpeg"].push_back(m->header.stamp.toSec());
        last_jpeg = m;
      }));
  subs.push_back(nh.subscribe<sensor_msgs::Image>(
      "camera_node/image/raw", 200, [&](const sensor_msgs::Image::ConstPtr& m) {
        log.stamps["raw"].push_back(m->header.stamp.toSec());
        last_raw = m;
      }));
  subs.push_back(nh.subscribe<sensor_msgs::CameraInfo>(
      "camera_node/camera_info", 10,
      [&](const sensor_msgs::CameraInfo::ConstPtr& m) { last_info = m; }));
  subs.push_back(nh.subscribe<WheelEncoderStamped>(
      "left_wheel_encoder_node/tick", 10,
      [&](const WheelEncoderStamped::ConstPtr& m) { last_tick = m; }));

  // Connected to every publisher first, then start the simulator (it holds time at 0 until a
  // node publishes on wheels_cmd).
  ASSERT_TRUE(spinUntil([&] { return allConnected(subs); }, 60.0));
  ros::Publisher start = nh.advertise<WheelsCmdStamped>("wheels_driver_node/wheels_cmd", 1);
  // Measure over a window of sim time well after the start.
  const double t0 = testParam<double>("window_start_s"), t1 = testParam<double>("window_end_s");
  ASSERT_TRUE(spinUntilSimTime(t1 + 0.3, 150.0)) << "sim time did not reach " << t1 << " s";
  ASSERT_TRUE(ros::Time::isSimTime());

  struct Expect {
    std::string topic;
    double rate_hz;
  };
  const std::vector<Expect> expected{
      {"left_wheel_encoder_node/tick", robot.encoder_rate_hz},
      {"right_wheel_encoder_node/tick", robot.encoder_rate_hz},
      {"front_center_tof_driver_node/range", robot.range_sensor.rate_hz},
      {"camera_node/camera_info", robot.camera.rate_hz},
      {"jpeg", robot.camera.rate_hz},
      {"raw", robot.camera.rate_hz},
      {"sim/ground_truth", testParam<double>("ground_truth_rate_hz")}};
  for (const Expect& e : expected) {
    // The rate the stamps are spaced at; and most of the messages arrived (at real_time_factor 0
    // on a loaded machine a publisher queue may drop a few). A subscriber counts a publisher
    // before their TCP handshake is done, and the simulator, started at once, may be seconds of
    // sim time ahead by then: the count starts at the first message received, at least 1 s before
    // the window's end.
    const std::vector<double>& got = log.stamps[e.topic];
    ASSERT_FALSE(got.empty()) << e.topic;
    const double from = std::max(t0, got.front());
    ASSERT_LT(from, t1 - 1.0) << e.topic << ": the first message came at " << got.front() << " s";
    EXPECT_NEAR(log.medianRateIn(e.topic, from, t1), e.rate_hz, tolerance * e.rate_hz) << e.topic;
    EXPECT_GE(log.rateIn(e.topic, from, t1), 0.8 * e.rate_hz) << e.topic;
    // Stamps are sim time: never going back, and not ahead of the clock (by more than the two
    // connections' delivery race: 10 clock periods).
    const std::vector<double>& s = log.stamps[e.topic];
    for (size_t i = 1; i < s.size(); ++i) ASSERT_GE(s[i], s[i - 1]) << e.topic;
    if (!s.empty()) {
      EXPECT_LE(s.back(), ros::Time::now().toSec() + 0.05) << e.topic;
    }
  }
  int clock_in_window = 0;
  for (double t : clock_s) clock_in_window += (t >= t0 && t < t1) ? 1 : 0;
  const double clock_hz = testParam<double>("clock_rate_hz");
  EXPECT_NEAR(clock_in_window / (t1 - t0), clock_hz, tolerance * clock_hz) << "/clock";

  // The images are what the config says, and camera_info carries the NOMINAL model, not the truth.
  ASSERT_TRUE(last_jpeg && last_raw && last_info && last_tick);
  EXPECT_EQ(last_jpeg->format, "jpeg");
  const cv::Mat decoded = cv::imdecode(last_jpeg->data, cv::IMREAD_COLOR);
  ASSERT_FALSE(decoded.empty()) << "the JPEG does not decode";
  EXPECT_EQ(decoded.cols, robot.camera.truth.width);
  EXPECT_EQ(decoded.rows, robot.camera.truth.height);
  EXPECT_EQ(last_raw->encoding, "bgr8");
  EXPECT_EQ(static_cast<int>(last_raw->width), robot.camera.truth.width);
  EXPECT_EQ(last_raw->data.size(), static_cast<size_t>(last_raw->step) * last_raw->height);
  EXPECT_DOUBLE_EQ(last_info->K[0], robot.camera.nominal.fx);
  EXPECT_DOUBLE_EQ(last_info->K[4], robot.camera.nominal.fy);
  EXPECT_NE(last_info->K[0], robot.camera.truth.fx);
  EXPECT_EQ(last_tick->resolution, robot.encoder_resolution);
  EXPECT_EQ(last_tick->type, WheelEncoderStamped::ENCODER_TYPE_INCREMENTAL);
  // A still robot's image is not flat: the scene is rendered.
  cv::Scalar mean, stddev;
  cv::meanStdDev(decoded, mean, stddev);
  EXPECT_GT(stddev[0], 10.0);
}

/// Ground truth and encoder ticks as they arrive.
struct DriveLog {
  std::vector<nav_msgs::Odometry> truth;
  int left_ticks = 0, right_ticks = 0;
  double left_stamp_s = 0, right_stamp_s = 0;
  bool have_ticks = false;
  const nav_msgs::Odometry& last() const { return truth.back(); }
  /// The last ground-truth sample stamped at or before t_s.
  const nav_msgs::Odometry* at(double t_s) const {
    const nav_msgs::Odometry* found = nullptr;
    for (const auto& o : truth)
      if (o.header.stamp.toSec() <= t_s) found = &o;
    return found;
  }
};

double distance(const nav_msgs::Odometry& a, const nav_msgs::Odometry& b) {
  return std::hypot(a.pose.pose.position.x - b.pose.pose.position.x,
                    a.pose.pose.position.y - b.pose.pose.position.y);
}

/// Sends one command (the simulator holds it until its watchdog).
void command(ros::Publisher& pub, float left, float right) {
  WheelsCmdStamped cmd;
  cmd.header.stamp = ros::Time::now();
  cmd.vel_left = left;
  cmd.vel_right = right;
  pub.publish(cmd);
}

/// Markers of namespace `ns`.
std::vector<visualization_msgs::Marker> markersOf(const visualization_msgs::MarkerArray& a,
                                                  const std::string& ns) {
  std::vector<visualization_msgs::Marker> out;
  for (const visualization_msgs::Marker& m : a.markers)
    if (m.ns == ns) out.push_back(m);
  return out;
}

TEST(SimNode, PublishesTheWorldAndTheTruePathForRviz) {
  const autocal::sim::WorldConfig world =
      autocal::sim::loadWorldConfig(testParam<std::string>("world_config"));
  const std::string veh = testParam<std::string>("veh");
  ros::NodeHandle nh(veh);
  visualization_msgs::MarkerArray::ConstPtr markers;
  ros::Subscriber markers_sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "sim/world_markers", 1,
      [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers = m; });
  std::vector<geometry_msgs::TransformStamped> static_tf;
  ros::Subscriber static_sub = ros::NodeHandle().subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 10, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
        static_tf.insert(static_tf.end(), m->transforms.begin(), m->transforms.end());
      });
  std::vector<nav_msgs::Odometry> truth;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100000,
      [&](const nav_msgs::Odometry::ConstPtr& m) { truth.push_back(*m); });
  nav_msgs::Path::ConstPtr path;
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>(
      "sim/true_path", 10, [&](const nav_msgs::Path::ConstPtr& m) { path = m; });

  // Latched, before simulated time runs (the simulator holds it at 0 until a wheels_cmd).
  ASSERT_TRUE(spinUntil([&] { return markers && !static_tf.empty(); }, 60.0))
      << "no world markers or static TF";
  EXPECT_EQ(markersOf(*markers, "floor").size(), 1u);
  EXPECT_EQ(markersOf(*markers, "walls").size(), world.walls.size());
  EXPECT_EQ(markersOf(*markers, "chessboards").size(), world.chessboards.size());
  EXPECT_EQ(markersOf(*markers, "floor_tags").size(), world.floor_tags.size());
  EXPECT_EQ(markersOf(*markers, "tag_ids").size(), world.floor_tags.size());
  EXPECT_EQ(markersOf(*markers, "obstacles").size(), world.obstacles.size());
  size_t dashes = 0;
  for (const autocal::sim::LaneLineConfig& l : world.lane_lines) {
    const double len = std::hypot(l.x1_m - l.x0_m, l.y1_m - l.y0_m);
    dashes += l.dash_m > 0 ? static_cast<size_t>(std::ceil(len / (l.dash_m + l.gap_m))) : 1;
  }
  EXPECT_EQ(markersOf(*markers, "lane_lines").size(), dashes);
  ASSERT_FALSE(world.walls.empty());
  const visualization_msgs::Marker wall = markersOf(*markers, "walls").front();
  EXPECT_EQ(wall.header.frame_id, "world");
  EXPECT_NEAR(wall.pose.position.x, 0.5 * (world.walls[0].x0_m + world.walls[0].x1_m), 1e-9);
  EXPECT_NEAR(wall.pose.position.y, 0.5 * (world.walls[0].y0_m + world.walls[0].y1_m), 1e-9);
  EXPECT_NEAR(wall.scale.z, world.walls[0].height_m, 1e-9);
  for (size_t i = 0; i < world.floor_tags.size(); ++i) {
    const visualization_msgs::Marker tag = markersOf(*markers, "floor_tags")[i];
    EXPECT_NEAR(tag.pose.position.x, world.floor_tags[i].pose.x_m, 1e-9);
    EXPECT_NEAR(tag.pose.position.y, world.floor_tags[i].pose.y_m, 1e-9);
    EXPECT_EQ(markersOf(*markers, "tag_ids")[i].text, std::to_string(world.floor_tags[i].id));
  }
  const std::vector<visualization_msgs::Marker> robot = markersOf(*markers, "robot");
  ASSERT_FALSE(robot.empty());
  for (const visualization_msgs::Marker& m : robot) {
    EXPECT_EQ(m.header.frame_id, veh + "/ground_truth/base_link");
    EXPECT_TRUE(m.frame_locked);
  }
  // The robot's start, where dead reckoning (the believed path) begins.
  const auto odom = std::find_if(static_tf.begin(), static_tf.end(),
                                 [&](const auto& t) { return t.child_frame_id == veh + "/odom"; });
  ASSERT_NE(odom, static_tf.end());
  EXPECT_EQ(odom->header.frame_id, "world");
  EXPECT_NEAR(odom->transform.translation.x, world.robot_start.x_m, 1e-9);
  EXPECT_NEAR(odom->transform.translation.y, world.robot_start.y_m, 1e-9);

  // Drive an arc; the true path follows the ground truth.
  ASSERT_TRUE(spinUntil([&] { return truth_sub.getNumPublishers() > 0; }, 60.0));
  ros::Publisher cmd_pub = nh.advertise<WheelsCmdStamped>("wheels_driver_node/wheels_cmd", 10);
  ASSERT_TRUE(spinUntil([&] { return cmd_pub.getNumSubscribers() > 0; }, 30.0));
  WheelsCmdStamped cmd;
  cmd.vel_left = static_cast<float>(testParam<double>("duty_left"));
  cmd.vel_right = static_cast<float>(testParam<double>("duty_right"));
  cmd_pub.publish(cmd);
  const double drive_s = testParam<double>("drive_s");
  ASSERT_TRUE(spinUntil(
      [&] { return !truth.empty() && truth.back().header.stamp.toSec() >= drive_s; }, 60.0));
  // The watchdog (longer than drive_s) has not stopped it: the robot still moves.
  EXPECT_GT(std::abs(truth.back().twist.twist.linear.x), 0.05);
  ASSERT_TRUE(spinUntil(
      [&] {
        return path && !path->poses.empty() && path->poses.back().header.stamp.toSec() >= drive_s;
      },
      60.0))
      << "no true path reaching " << drive_s << " s of sim time";
  EXPECT_EQ(path->header.frame_id, "world");
  EXPECT_GT(path->poses.size(), 20u);
  EXPECT_NEAR(path->poses.front().pose.position.x, world.robot_start.x_m, 1e-6);
  EXPECT_NEAR(path->poses.front().pose.position.y, world.robot_start.y_m, 1e-6);
  // Every pose of the path is a ground-truth sample of the same stamp.
  std::map<double, geometry_msgs::Pose> truth_at;
  for (const nav_msgs::Odometry& m : truth) truth_at[m.header.stamp.toSec()] = m.pose.pose;
  const double step_m = testParam<double>("path_step_m");
  for (size_t i = 0; i < path->poses.size(); ++i) {
    const geometry_msgs::PoseStamped& p = path->poses[i];
    const auto it = truth_at.find(p.header.stamp.toSec());
    if (it == truth_at.end()) continue;  // published before this test subscribed
    EXPECT_NEAR(p.pose.position.x, it->second.position.x, 1e-9) << i;
    EXPECT_NEAR(p.pose.position.y, it->second.position.y, 1e-9) << i;
    if (i == 0) continue;
    const geometry_msgs::Point& a = path->poses[i - 1].pose.position;
    const double moved = std::hypot(p.pose.position.x - a.x, p.pose.position.y - a.y);
    const double turned = std::abs(
        std::remainder(autocal::ros_layer::quaternionToYaw(p.pose.orientation) -
                           autocal::ros_layer::quaternionToYaw(path->poses[i - 1].pose.orientation),
                       2 * M_PI));
    EXPECT_TRUE(moved >= step_m - 1e-12 || turned >= 0.02) << i << ": thinned poses only";
  }
}

/// Each message's delay: the sim time it arrived at less its header stamp.
struct DelayLog {
  std::vector<double> stamps, delays;
  template <class M>
  ros::Subscriber track(ros::NodeHandle& nh, const std::string& topic) {
    return nh.subscribe<M>(topic, 2000, [this](const boost::shared_ptr<const M>& m) {
      stamps.push_back(m->header.stamp.toSec());
      delays.push_back(ros::Time::now().toSec() - m->header.stamp.toSec());
    });
  }
  double median() const {
    std::vector<double> d = delays;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d[d.size() / 2];
  }
  bool ordered() const { return std::is_sorted(stamps.begin(), stamps.end()); }
};

// Robot mode with robot.yaml's transport: every message arrives its link's latency after its
// capture stamp, in order; frames are lost at the link's rate; a command moves the wheels its
// link's latency after it was sent (on the ground truth). At real_time_factor 1, on sim time.
TEST(SimNode, MessagesArriveLateWithTheirCaptureStampsInOrder) {
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  ASSERT_TRUE(robot.transport.camera.active()) << "the test needs a robot with late messages";
  ros::NodeHandle nh(testParam<std::string>("veh"));
  DelayLog left, info, range;
  std::vector<ros::Subscriber> subs{
      left.track<WheelEncoderStamped>(nh, "left_wheel_encoder_node/tick"),
      info.track<sensor_msgs::CameraInfo>(nh, "camera_node/camera_info"),
      range.track<sensor_msgs::Range>(nh, "front_center_tof_driver_node/range")};
  std::vector<nav_msgs::Odometry> truth;
  subs.push_back(nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 10000,
      [&](const nav_msgs::Odometry::ConstPtr& m) { truth.push_back(*m); }));
  ASSERT_TRUE(spinUntil([&] { return allConnected(subs); }, 60.0));
  ros::Publisher cmd_pub = nh.advertise<WheelsCmdStamped>("wheels_driver_node/wheels_cmd", 10);
  ASSERT_TRUE(spinUntil([&] { return cmd_pub.getNumSubscribers() > 0; }, 30.0));
  ASSERT_TRUE(spinUntilSimTime(1.0, 60.0));
  // Commands: five pulses from rest; the first ground-truth sample that moves after each.
  std::vector<double> command_delays;
  for (int i = 0; i < 5; ++i) {
    const double sent = ros::Time::now().toSec();
    command(cmd_pub, 0.5f, 0.5f);
    double moved = NAN;
    ASSERT_TRUE(spinUntil(
        [&] {
          for (const auto& o : truth)
            if (o.header.stamp.toSec() > sent && std::abs(o.twist.twist.linear.x) > 1e-3) {
              moved = o.header.stamp.toSec();
              return true;
            }
          return false;
        },
        10.0));
    command_delays.push_back(moved - sent);
    command(cmd_pub, 0.0f, 0.0f);
    const double stop = ros::Time::now().toSec();
    ASSERT_TRUE(spinUntilSimTime(stop + 0.5, 10.0));
    truth.clear();
  }
  ASSERT_TRUE(spinUntilSimTime(6.0, 60.0));

  const double truth_period_s = 1.0 / testParam<double>("ground_truth_rate_hz");
  const double clock_s = testParam<double>("clock_period_s");
  struct Link {
    const char* name;
    const DelayLog& log;
    const autocal::sim::LinkConfig& config;
  };
  for (const Link& l : {Link{"encoders", left, robot.transport.encoders},
                        Link{"camera", info, robot.transport.camera},
                        Link{"range", range, robot.transport.range}}) {
    ASSERT_GT(l.log.delays.size(), 20u) << l.name;
    EXPECT_TRUE(l.log.ordered()) << l.name << ": a message overtook another";
    // The median delay: the latency, to the clock's resolution and the subscriber's own lag.
    EXPECT_GT(l.log.median(), l.config.latency_s - 0.5 * l.config.jitter_s) << l.name;
    EXPECT_LT(l.log.median(), l.config.latency_s + 0.5 * l.config.jitter_s + clock_s + 0.01)
        << l.name;
  }
  // Frames (with their camera_info) lost at the camera link's rate, over the run so far.
  const double frames = info.stamps.size(), expected = robot.camera.rate_hz * info.stamps.back();
  EXPECT_NEAR(frames / expected, 1.0 - robot.transport.camera.drop_probability, 0.08);
  std::sort(command_delays.begin(), command_delays.end());
  const double command_median = command_delays[2];
  EXPECT_GT(command_median, robot.transport.wheels_cmd.latency_s - robot.transport.wheels_cmd.jitter_s);
  EXPECT_LT(command_median, robot.transport.wheels_cmd.latency_s +
                                robot.transport.wheels_cmd.jitter_s + truth_period_s + clock_s + 0.01);
}

TEST(SimNode, MovesOnWheelsCmdAndTheWatchdogStopsIt) {
  const autocal::sim::RobotConfig robot =
      autocal::sim::loadRobotConfig(testParam<std::string>("robot_config"));
  ros::NodeHandle nh(testParam<std::string>("veh"));
  const double watchdog_s = testParam<double>("watchdog_s");
  const double duty = testParam<double>("duty");
  DriveLog log;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "sim/ground_truth", 100000,
      [&](const nav_msgs::Odometry::ConstPtr& m) { log.truth.push_back(*m); });
  ros::Subscriber left_sub = nh.subscribe<WheelEncoderStamped>(
      "left_wheel_encoder_node/tick", 10000, [&](const WheelEncoderStamped::ConstPtr& m) {
        log.left_ticks = m->data;
        log.left_stamp_s = m->header.stamp.toSec();
        log.have_ticks = true;
      });
  ros::Subscriber right_sub = nh.subscribe<WheelEncoderStamped>(
      "right_wheel_encoder_node/tick", 10000, [&](const WheelEncoderStamped::ConstPtr& m) {
        log.right_ticks = m->data;
        log.right_stamp_s = m->header.stamp.toSec();
      });
  ASSERT_TRUE(spinUntil(
      [&] {
        return truth_sub.getNumPublishers() > 0 && left_sub.getNumPublishers() > 0 &&
               right_sub.getNumPublishers() > 0;
      },
      60.0));
  // The simulator starts its clock when this publisher connects.
  ros::Publisher cmd_pub = nh.advertise<WheelsCmdStamped>("wheels_driver_node/wheels_cmd", 10);
  // The ground truth lags /clock in transport at real_time_factor 0: wait for the samples
  // themselves to reach a time.
  auto truthUntil = [&](double t_s) {
    return spinUntil(
        [&] { return !log.truth.empty() && log.truth.back().header.stamp.toSec() >= t_s; }, 60.0);
  };
  ASSERT_TRUE(spinUntil([&] { return cmd_pub.getNumSubscribers() > 0; }, 30.0))
      << "the simulator does not listen to wheels_cmd";

  // At real_time_factor 0 the simulator may be far ahead already: wait for data, not a time.
  ASSERT_TRUE(spinUntil([&] { return log.have_ticks && log.truth.size() > 10; }, 60.0));
  // Untouched, the robot stands still.
  const nav_msgs::Odometry start = log.last();
  const int left0 = log.left_ticks, right0 = log.right_ticks;
  EXPECT_LT(std::abs(start.pose.pose.position.x), 1e-6);

  // One command, backwards (the boards are in front of the robot); the watchdog ends it. At
  // real_time_factor 0 some ground-truth samples may be lost in transport, so every check below
  // uses still poses, cumulative ticks, or any sample of a long window.
  // The command reaches the simulator at a sim time the test cannot know in advance (at
  // real_time_factor 0 the simulator runs far ahead of its subscribers): the first sample that
  // moves tells it.
  const double t_sent = log.truth.back().header.stamp.toSec();
  command(cmd_pub, static_cast<float>(duty), static_cast<float>(duty));
  double t_go = NAN;
  ASSERT_TRUE(spinUntil(
      [&] {
        for (const auto& o : log.truth) {
          if (o.header.stamp.toSec() > t_sent && std::abs(o.twist.twist.linear.x) > 1e-3) {
            t_go = o.header.stamp.toSec();
            return true;
          }
        }
        return false;
      },
      60.0))
      << "the robot never moved";
  const double settled = t_go + watchdog_s + robot.motor_time_constant * 10 + 0.5;
  ASSERT_TRUE(truthUntil(settled + 1.5));
  double fastest = 0;  // most negative speed seen while the command was held
  for (const auto& o : log.truth) {
    if (o.header.stamp.toSec() > t_sent) fastest = std::min(fastest, o.twist.twist.linear.x);
  }
  // Expected speed from the config: (|duty| - deadband) / (1 - deadband) of the full wheel speed.
  const double wheel_rad_s =
      robot.motor_constant * (std::abs(duty) - robot.deadband) / (1.0 - robot.deadband);
  const double v_expected = 0.5 * wheel_rad_s *
                            (robot.motor_gain_left * robot.wheel_radius_left +
                             robot.motor_gain_right * robot.wheel_radius_right);
  const double tolerance = testParam<double>("distance_tolerance");
  EXPECT_NEAR(fastest, -v_expected, tolerance * v_expected) << "the speed the duty should give";

  // The command is held for the watchdog's timeout (the motor lag adds as much at the end as it
  // takes at the start), then the robot stands still.
  // Copies: the log keeps growing (and moving) while the test spins on.
  ASSERT_TRUE(log.at(settled) && log.at(settled + 1.5));
  const nav_msgs::Odometry still_a = *log.at(settled), still_b = *log.at(settled + 1.5);
  const nav_msgs::Odometry *a = &still_a, *b = &still_b;
  const double driven = distance(*b, start);
  EXPECT_NEAR(driven, v_expected * watchdog_s, tolerance * v_expected * watchdog_s)
      << "the watchdog should end the command after " << watchdog_s << " s";
  EXPECT_LT(b->pose.pose.position.x, start.pose.pose.position.x - 0.3) << "not backwards";
  const double still_m = testParam<double>("still_tolerance_m");
  EXPECT_LT(distance(*a, *b), still_m) << "the watchdog did not stop the robot";
  EXPECT_LT(std::abs(b->twist.twist.linear.x), 1e-3);
  // Encoders counted the way back: ticks x 2 pi r / resolution ~ distance (the tick streams, too,
  // lag the simulator: wait for them to reach the still robot).
  ASSERT_TRUE(spinUntil(
      [&] { return std::min(log.left_stamp_s, log.right_stamp_s) >= settled + 1.5; }, 60.0));
  const double left_m =
      (log.left_ticks - left0) * 2 * M_PI * robot.wheel_radius_left / robot.encoder_resolution;
  const double right_m =
      (log.right_ticks - right0) * 2 * M_PI * robot.wheel_radius_right / robot.encoder_resolution;
  EXPECT_LT(left_m, 0.0);
  EXPECT_NEAR(0.5 * (left_m + right_m), -driven, testParam<double>("encoder_tolerance_m"));

  // Bad commands: NaN is dropped (the robot stays still), |duty| > 1 is clamped to 1.
  const double t_nan = log.truth.back().header.stamp.toSec();
  command(cmd_pub, std::nanf(""), std::nanf(""));
  ASSERT_TRUE(truthUntil(t_nan + 3.0));
  EXPECT_LT(distance(log.last(), *b), still_m) << "a NaN command moved the robot";
  const double t_fast = log.truth.back().header.stamp.toSec();
  command(cmd_pub, 5.0f, 5.0f);
  // The plateau lasts the watchdog's timeout: wait until the robot has stopped again.
  double top_speed = 0;
  ASSERT_TRUE(spinUntil(
      [&] {
        double last_v = 1;
        for (const auto& o : log.truth) {
          if (o.header.stamp.toSec() <= t_fast) continue;
          top_speed = std::max(top_speed, o.twist.twist.linear.x);
          last_v = o.twist.twist.linear.x;
        }
        return top_speed > 0.1 && std::abs(last_v) < 1e-3;
      },
      60.0));
  const double full_speed = 0.5 * robot.motor_constant *
                            (robot.motor_gain_left * robot.wheel_radius_left +
                             robot.motor_gain_right * robot.wheel_radius_right);
  EXPECT_NEAR(top_speed, full_speed, testParam<double>("full_speed_tolerance") * full_speed);
  command(cmd_pub, 0.0f, 0.0f);
}

/// Runs the node binary with the given arguments; returns its exit status and output.
int runNode(const std::string& args, std::string* output) {
  // A new node name per run: private parameters set by `_key:=value` stay on the master.
  static int run = 0;
  const std::string cmd = std::string(SIM_NODE_BIN) + " __name:=sim_under_test_" +
                          std::to_string(++run) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return -1;
  char buffer[512];
  while (fgets(buffer, sizeof(buffer), pipe)) output->append(buffer);
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string writeTemp(const std::string& name, const std::string& contents) {
  const std::string path = "/tmp/autocal_test_sim_" + std::to_string(getpid()) + "_" + name;
  std::ofstream(path) << contents;
  return path;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A fleet's frames due at once are rendered on threads, each robot's on its own: every robot's
// image must be what its own renderer (its config, its seed) makes of its pose. The robots stand
// still (nobody commands them) at the world's start, so the only unknown is how many frames the
// node rendered before the one compared (each frame draws its noise offset from the robot's
// camera noise source): the candidates are searched, and exactly one must match.
TEST(SimNode, FleetFramesAreEachRobotsOwnRender) {
  const std::vector<std::string> vehicles = autocal::splitCommaList(testParam<std::string>("vehicles"));
  const std::vector<std::string> configs =
      autocal::splitCommaList(testParam<std::string>("robot_configs"));
  const autocal::sim::WorldConfig world =
      autocal::sim::loadWorldConfig(testParam<std::string>("world_config"));
  const int seed = testParam<int>("seed");
  ASSERT_EQ(vehicles.size(), configs.size());
  const size_t n = vehicles.size();
  const int kFrame = 12;  // the frame compared: by then every robot's frames come at once
  std::vector<cv::Mat> frame(n);
  std::vector<int> received(n, 0);
  ros::NodeHandle nh;
  std::vector<ros::Subscriber> subs;
  std::vector<ros::Publisher> cmd_pubs;
  for (size_t i = 0; i < n; ++i) {
    subs.push_back(nh.subscribe<sensor_msgs::Image>(
        "/" + vehicles[i] + "/camera_node/image/raw", 100,
        [&, i](const sensor_msgs::Image::ConstPtr& m) {
          if (++received[i] != kFrame) return;
          frame[i] = cv::Mat(static_cast<int>(m->height), static_cast<int>(m->width), CV_8UC3,
                             const_cast<uint8_t*>(m->data.data()), m->step)
                         .clone();
        }));
  }
  ASSERT_TRUE(spinUntil(
      [&] {
        for (const auto& s : subs) {
          if (s.getNumPublishers() == 0) return false;
        }
        return true;
      },
      60.0));
  // The simulator holds time at 0 until every robot's wheels_cmd has a publisher: these (never
  // publishing) start it once every image topic is subscribed.
  for (const std::string& v : vehicles)
    cmd_pubs.push_back(nh.advertise<WheelsCmdStamped>("/" + v + "/wheels_driver_node/wheels_cmd", 1));
  ASSERT_TRUE(spinUntil(
      [&] { return std::all_of(frame.begin(), frame.end(), [](const cv::Mat& f) { return !f.empty(); }); },
      60.0));
  for (size_t i = 0; i < n; ++i) {
    const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(configs[i]);
    // As the node builds robot i (sim_robot.cpp): seed + i for the renderer's noise table, and
    // its camera noise source seeded (seed + i) * 2 + 1.
    autocal::sim::RenderOptions o;
    o.supersampling = robot.camera.supersampling;
    o.noise_sigma = robot.camera.noise_sigma;
    o.noise_seed = static_cast<uint64_t>(seed + static_cast<int>(i));
    autocal::sim::Renderer renderer(robot.camera, world, o);
    std::mt19937_64 rng(static_cast<uint64_t>(seed + static_cast<int>(i)) * 2 + 1);
    ASSERT_EQ(frame[i].size(), cv::Size(robot.camera.truth.width, robot.camera.truth.height));
    int matches = 0;
    double nearest_other = 1e9;
    for (int k = 0; k < 400; ++k) {
      const cv::Mat candidate = renderer.render({world.robot_start}, rng);
      const double diff = cv::norm(candidate, frame[i], cv::NORM_L1) / static_cast<double>(candidate.total() * 3);
      if (diff == 0) {
        ++matches;
      } else {
        nearest_other = std::min(nearest_other, diff);
      }
    }
    EXPECT_EQ(matches, 1) << vehicles[i] << ": its frame " << kFrame
                          << " is not exactly one of its own renderer's first 400";
    EXPECT_GT(nearest_other, 1.0) << vehicles[i];  // other frames differ by their noise
  }
}

TEST(SimNode, BadConfigMakesTheNodeExitNonZero) {
  const std::string good_robot = readAll(robotConfigPath());
  ASSERT_FALSE(good_robot.empty());
  const std::string world = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world.yaml";
  const std::string required = " _robot_config:=" + robotConfigPath() + " _world_config:=" + world;
  const std::string common =
      "__ns:=/badcfg _real_time_factor:=0 _camera_enabled:=false _duration_s:=0.2 "
      "_failure_linger_s:=0.1";
  const int bad_config = autocal::toInt(autocal::ExitCode::kBadConfig);

  // Control: the shipped config runs and ends cleanly, so a failure below is the config's doing.
  {
    std::string out;
    EXPECT_EQ(runNode(common + required, &out), 0) << out;
  }
  // Each required parameter, missing, stops the node with the bad-configuration code, naming it.
  for (const std::string missing : {"robot_config", "world_config"}) {
    const std::string other = missing == "robot_config" ? " _world_config:=" + world
                                                        : " _robot_config:=" + robotConfigPath();
    std::string out;
    EXPECT_EQ(runNode(common + other, &out), bad_config) << missing << ": " << out;
    EXPECT_NE(out.find("~" + missing + ": required parameter is missing"), std::string::npos)
        << out;
  }
  // A parameter of the wrong type or out of range names the key.
  for (const std::string& bad :
       {std::string(" _seed:=-1"), std::string(" _physics_rate_hz:=abc"),
        std::string(" _render_threads:=-1")}) {
    std::string out;
    EXPECT_EQ(runNode(common + required + bad, &out), bad_config) << bad << ": " << out;
    const std::string key = bad.substr(2, bad.find(":=") - 2);
    EXPECT_NE(out.find("~" + key), std::string::npos) << bad << ": " << out;
  }
  struct Case {
    std::string name, contents, must_mention;
  };
  std::string unknown = good_robot + "\nwheel_radius_lft: 0.03\n";
  std::string malformed = good_robot;
  malformed.replace(malformed.find("wheelbase: 0.102"), 16, "wheelbase: abc  ");
  std::string negative = good_robot;
  negative.replace(negative.find("wheelbase: 0.102"), 16, "wheelbase: -0.1 ");
  const std::vector<Case> cases{{"unknown.yaml", unknown, "wheel_radius_lft"},
                                {"malformed.yaml", malformed, "wheelbase"},
                                {"negative.yaml", negative, "wheelbase"},
                                {"not_yaml.yaml", "camera: [unclosed\n", "not_yaml.yaml"}};
  for (const Case& c : cases) {
    const std::string path = writeTemp(c.name, c.contents);
    std::string out;
    const int status =
        runNode(common + " _world_config:=" + world + " _robot_config:=" + path, &out);
    EXPECT_EQ(status, bad_config) << c.name << ": " << out;
    EXPECT_NE(out.find(path), std::string::npos)
        << c.name << ": the error does not name the file: " << out;
    EXPECT_NE(out.find(c.must_mention), std::string::npos) << c.name << ": " << out;
    std::remove(path.c_str());
  }
  {
    std::string out;
    EXPECT_EQ(runNode(common + " _robot_config:=" + robotConfigPath() +
                          " _world_config:=/nonexistent/world.yaml",
                      &out),
              bad_config)
        << out;
    EXPECT_NE(out.find("/nonexistent/world.yaml"), std::string::npos) << out;
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_node", ros::init_options::AnonymousName);
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
