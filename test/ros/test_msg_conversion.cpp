// Every conversion of the ROS layer, without a master: round trips, the values ROS expects, and
// the messages that must be refused.
#include <camera_calibration_parsers/parse_yml.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "autocal/errors.h"
#include "autocal_ros/msg_conversion.h"

using namespace autocal;
using namespace autocal::ros_layer;

namespace {

CameraIntrinsics duckiebotLens() {
  CameraIntrinsics in;
  in.width = 640;
  in.height = 480;
  in.fx = 318.0;
  in.fy = 320.5;
  in.cx = 325.4;
  in.cy = 236.8;
  in.distortion_coefficients = {-0.27, 0.06, 0.001, -0.002, 0.0};
  return in;
}

}  // namespace

TEST(MsgConversion, CameraInfoRoundTripAndProjection) {
  const CameraIntrinsics in = duckiebotLens();
  const sensor_msgs::CameraInfo ci = toCameraInfo(in);
  EXPECT_EQ(ci.width, 640u);
  EXPECT_EQ(ci.height, 480u);
  EXPECT_EQ(ci.distortion_model, "plumb_bob");
  EXPECT_EQ(ci.K[0], 318.0);
  EXPECT_EQ(ci.K[2], 325.4);
  EXPECT_EQ(ci.K[4], 320.5);
  EXPECT_EQ(ci.K[5], 236.8);
  EXPECT_EQ(ci.K[8], 1.0);
  EXPECT_EQ(ci.R[0] + ci.R[4] + ci.R[8], 3.0);
  // P is OpenCV's optimal new camera matrix with alpha 0, as ROS camera_calibration writes it.
  const cv::Mat p = cv::getOptimalNewCameraMatrix(
      cv::Mat(in.cameraMatrix()), cv::Mat(in.distortion_coefficients), in.imageSize(), 0.0);
  EXPECT_NEAR(ci.P[0], p.at<double>(0, 0), 1e-9);
  EXPECT_NEAR(ci.P[2], p.at<double>(0, 2), 1e-9);
  EXPECT_NEAR(ci.P[5], p.at<double>(1, 1), 1e-9);
  EXPECT_EQ(ci.P[3], 0.0);
  EXPECT_EQ(ci.P[10], 1.0);
  EXPECT_LT(ci.P[0], in.fx) << "barrel distortion: the valid-pixel rectified image zooms in";

  const CameraIntrinsics back = fromCameraInfo(ci);
  EXPECT_EQ(back.width, in.width);
  EXPECT_EQ(back.height, in.height);
  EXPECT_EQ(back.fx, in.fx);
  EXPECT_EQ(back.fy, in.fy);
  EXPECT_EQ(back.cx, in.cx);
  EXPECT_EQ(back.cy, in.cy);
  EXPECT_EQ(back.distortion_coefficients, in.distortion_coefficients);
  EXPECT_EQ(back.distortion_model, DistortionModel::kPlumbBob);

  CameraIntrinsics no_distortion = in;
  no_distortion.distortion_coefficients.assign(5, 0.0);
  const sensor_msgs::CameraInfo flat = toCameraInfo(no_distortion);
  // Without distortion, P is K up to OpenCV's sampled valid-region border (under 0.5 %).
  EXPECT_NEAR(flat.P[0], in.fx, 0.005 * in.fx);
  EXPECT_NEAR(flat.P[5], in.fy, 0.005 * in.fy);
}

TEST(MsgConversion, FisheyeCameraInfo) {
  CameraIntrinsics in = duckiebotLens();
  in.distortion_model = DistortionModel::kEquidistant;
  in.distortion_coefficients = {0.05, -0.01, 0.002, 0.0};
  const sensor_msgs::CameraInfo ci = toCameraInfo(in);
  EXPECT_EQ(ci.distortion_model, "equidistant");
  EXPECT_TRUE(std::isfinite(ci.P[0]) && ci.P[0] > 0);
  EXPECT_EQ(fromCameraInfo(ci).distortion_coefficients, in.distortion_coefficients);
}

TEST(MsgConversion, BadCameraInfoIsRefused) {
  const sensor_msgs::CameraInfo good = toCameraInfo(duckiebotLens());
  sensor_msgs::CameraInfo bad = good;
  bad.distortion_model = "kannala";
  EXPECT_THROW(fromCameraInfo(bad), InputError);
  bad = good;
  bad.D.resize(4);
  EXPECT_THROW(fromCameraInfo(bad), InputError);
  bad = good;
  bad.width = 0;
  EXPECT_THROW(fromCameraInfo(bad), InputError);
  bad = good;
  bad.K[0] = std::nan("");
  EXPECT_THROW(fromCameraInfo(bad), InputError);
  bad = good;
  bad.D[1] = INFINITY;
  EXPECT_THROW(fromCameraInfo(bad), InputError);
}

TEST(MsgConversion, CameraInfoYamlReadsBackWithTheRosParsers) {
  const CameraIntrinsics in = duckiebotLens();
  const std::string yaml = cameraInfoYaml(in, "autobot");
  std::istringstream stream(yaml);
  std::string name;
  sensor_msgs::CameraInfo ci;
  ASSERT_TRUE(camera_calibration_parsers::readCalibrationYml(stream, name, ci)) << yaml;
  EXPECT_EQ(name, "autobot");
  const CameraIntrinsics back = fromCameraInfo(ci);
  EXPECT_NEAR(back.fx, in.fx, 1e-6);
  EXPECT_NEAR(back.cy, in.cy, 1e-6);
  ASSERT_EQ(back.distortion_coefficients.size(), 5u);
  EXPECT_NEAR(back.distortion_coefficients[0], -0.27, 1e-9);
}

TEST(MsgConversion, EncodersAndWheelCommands) {
  const EncoderReading r{12.25, -2147483000, 135};
  const auto msg = toEncoderMsg(r, "autobot/left_wheel_axis");
  EXPECT_EQ(msg.header.frame_id, "autobot/left_wheel_axis");
  EXPECT_EQ(msg.type, dtmsg::WheelEncoderStamped::ENCODER_TYPE_INCREMENTAL);
  const EncoderReading back = fromEncoderMsg(msg);
  EXPECT_EQ(back.ticks, r.ticks);
  EXPECT_EQ(back.ticks_per_revolution, 135);
  EXPECT_DOUBLE_EQ(back.stamp_s, 12.25);
  dtmsg::WheelEncoderStamped zero = msg;
  zero.resolution = 0;
  EXPECT_THROW(fromEncoderMsg(zero), InputError);

  const auto cmd = toWheelsCmd({0.25, -0.5}, ros::Time(3.0));
  EXPECT_FLOAT_EQ(cmd.vel_left, 0.25f);
  EXPECT_FLOAT_EQ(cmd.vel_right, -0.5f);
  EXPECT_EQ(cmd.header.stamp, ros::Time(3.0));
  const WheelDuties d = fromWheelsCmd(cmd);
  EXPECT_DOUBLE_EQ(d.left, 0.25);
  EXPECT_DOUBLE_EQ(d.right, -0.5);
}

TEST(MsgConversion, CarCommands) {
  const auto msg = toCarCmd({0.25, -1.5}, ros::Time(4.5));
  EXPECT_FLOAT_EQ(msg.v, 0.25f);
  EXPECT_FLOAT_EQ(msg.omega, -1.5f);
  EXPECT_EQ(msg.header.stamp, ros::Time(4.5));
  const wheels::CarCommand back = fromCarCmd(msg);
  EXPECT_DOUBLE_EQ(back.v_mps, 0.25);
  EXPECT_DOUBLE_EQ(back.omega_radps, -1.5);
  dtmsg::Twist2DStamped nan = msg;
  nan.omega = std::nanf("");
  EXPECT_TRUE(std::isnan(fromCarCmd(nan).omega_radps)) << "passed on for the node to refuse";
}

TEST(MsgConversion, TagDetectionRoundTrip) {
  markers::TagDetection t;
  t.id = 17;
  t.family = "tag36h11";
  t.hamming = 1;
  t.decision_margin = 48.5;
  t.center_px = {320.5, 240.25};
  t.corners_px = {{{300, 220}, {340, 221}, {341, 260}, {299, 259}}};
  t.homography = cv::Matx33d(1, 0.1, 320, 0, 1.1, 240, 0, 0.001, 1);
  cv::Matx33d rot;
  cv::Rodrigues(cv::Vec3d(0.3, -1.2, 2.9), rot);  // near the 180° branch of the conversion
  t.rotation = rot;
  t.translation_m = {0.05, 0.08, 0.3};
  t.pose_error = 1e-4;
  const markers::TagDetection back = fromTagDetectionMsg(toTagDetectionMsg(t));
  EXPECT_EQ(back.id, 17);
  EXPECT_EQ(back.family, "tag36h11");
  EXPECT_EQ(back.hamming, 1);
  EXPECT_FLOAT_EQ(static_cast<float>(back.decision_margin), 48.5f);
  EXPECT_NEAR(back.center_px.y, 240.25, 1e-4);
  EXPECT_NEAR(back.corners_px[2].x, 341, 1e-4);
  EXPECT_NEAR(back.corners_px[3].y, 259, 1e-4);
  EXPECT_NEAR(back.homography(2, 1), 0.001, 1e-7);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(back.rotation.val[i], rot.val[i], 1e-9) << i;
  EXPECT_NEAR(back.translation_m[2], 0.3, 1e-12);
  for (const cv::Vec3d& r : {cv::Vec3d(0, 0, 0), cv::Vec3d(M_PI, 0, 0), cv::Vec3d(0, M_PI, 0),
                            cv::Vec3d(0, 0, M_PI), cv::Vec3d(0.1, 0.2, -0.3)}) {
    cv::Rodrigues(r, rot);
    t.rotation = rot;
    const markers::TagDetection b = fromTagDetectionMsg(toTagDetectionMsg(t));
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(b.rotation.val[i], rot.val[i], 1e-9) << r << " " << i;
  }
}

TEST(MsgConversion, PlanarPosesAndTime) {
  for (double yaw : {0.0, 0.5, -2.0, 3.1, -3.1, M_PI}) {
    const Pose2D p{1.5, -0.25, yaw};
    const Pose2D a = fromPoseMsg(toPoseMsg(p));
    const Pose2D b = fromTransformMsg(toTransformMsg(p));
    for (const Pose2D& q : {a, b}) {
      EXPECT_DOUBLE_EQ(q.x_m, 1.5);
      EXPECT_DOUBLE_EQ(q.y_m, -0.25);
      EXPECT_NEAR(std::remainder(q.yaw_rad - yaw, 2 * M_PI), 0.0, 1e-12) << yaw;
    }
  }
  const geometry_msgs::Quaternion q = yawToQuaternion(M_PI / 2);
  EXPECT_NEAR(q.z, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(q.w, std::sqrt(0.5), 1e-12);
  EXPECT_DOUBLE_EQ(toSeconds(toRosTime(12.5)), 12.5);
  EXPECT_EQ(toRosTime(-1.0), ros::Time(0));
}

TEST(MsgConversion, RangeKeepsRep117Values) {
  sensor_msgs::Range msg;
  msg.header.stamp = ros::Time(12, 500000000);
  msg.min_range = 0.03f;
  msg.max_range = 2.0f;
  msg.range = 1.25f;
  RangeReading r = fromRangeMsg(msg);
  EXPECT_DOUBLE_EQ(r.stamp_s, 12.5);
  EXPECT_FLOAT_EQ(r.range_m, 1.25);
  EXPECT_FLOAT_EQ(r.min_range_m, 0.03);
  EXPECT_FLOAT_EQ(r.max_range_m, 2.0);
  msg.range = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(std::isinf(fromRangeMsg(msg).range_m) && fromRangeMsg(msg).range_m > 0);
  msg.range = -std::numeric_limits<float>::infinity();
  EXPECT_TRUE(std::isinf(fromRangeMsg(msg).range_m) && fromRangeMsg(msg).range_m < 0);
}
