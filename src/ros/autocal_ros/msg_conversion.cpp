#include "autocal_ros/msg_conversion.h"

#include <camera_calibration_parsers/parse.h>
#include <camera_calibration_parsers/parse_yml.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "autocal/errors.h"

namespace autocal {
namespace ros_layer {

double toSeconds(const ros::Time& stamp) { return stamp.toSec(); }

ros::Time toRosTime(double stamp_s) { return ros::Time(std::max(0.0, stamp_s)); }

sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& in) {
  sensor_msgs::CameraInfo ci;
  ci.width = static_cast<uint32_t>(in.width);
  ci.height = static_cast<uint32_t>(in.height);
  ci.distortion_model = distortionModelName(in.distortion_model);
  ci.D = in.distortion_coefficients;
  ci.K = {in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1};
  ci.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  cv::Mat p;
  const cv::Mat k(in.cameraMatrix());
  const cv::Mat d(in.distortion_coefficients);
  if (in.distortion_model == DistortionModel::kEquidistant) {
    cv::fisheye::estimateNewCameraMatrixForUndistortRectify(k, d, in.imageSize(),
                                                            cv::Mat::eye(3, 3, CV_64F), p, 0.0);
  } else {
    p = cv::getOptimalNewCameraMatrix(k, d, in.imageSize(), 0.0);
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) ci.P[static_cast<size_t>(r * 4 + c)] = p.at<double>(r, c);
  }
  return ci;
}

CameraIntrinsics fromCameraInfo(const sensor_msgs::CameraInfo& info) {
  CameraIntrinsics in;
  if (info.width == 0 || info.height == 0) {
    throw InputError("camera_info has no image size (" + std::to_string(info.width) + "x" +
                     std::to_string(info.height) + ")");
  }
  in.width = static_cast<int>(info.width);
  in.height = static_cast<int>(info.height);
  try {
    in.distortion_model = parseDistortionModel(info.distortion_model);
  } catch (const Error& e) {
    throw InputError("camera_info: " + std::string(e.what()));
  }
  const size_t expected = distortionCoefficientCount(in.distortion_model);
  if (info.D.size() != expected) {
    throw InputError("camera_info: " + info.distortion_model + " needs " +
                     std::to_string(expected) + " distortion coefficients, got " +
                     std::to_string(info.D.size()));
  }
  in.distortion_coefficients = info.D;
  in.fx = info.K[0];
  in.cx = info.K[2];
  in.fy = info.K[4];
  in.cy = info.K[5];
  for (double v : {in.fx, in.fy, in.cx, in.cy}) {
    if (!std::isfinite(v)) throw InputError("camera_info: K is not finite");
  }
  for (double v : in.distortion_coefficients) {
    if (!std::isfinite(v)) throw InputError("camera_info: D is not finite");
  }
  return in;
}

CameraIntrinsics readIntrinsicsFile(const std::string& path, const std::string& why) {
  sensor_msgs::CameraInfo info;
  std::string camera_name;
  if (!camera_calibration_parsers::readCalibration(path, camera_name, info) || info.K[0] <= 0)
    throw ConfigError("the camera intrinsics '" + path + "' cannot be read (" + why + ")");
  return fromCameraInfo(info);
}

std::string cameraInfoYaml(const CameraIntrinsics& intrinsics, const std::string& camera_name) {
  std::ostringstream yaml;
  if (!camera_calibration_parsers::writeCalibrationYml(yaml, camera_name,
                                                       toCameraInfo(intrinsics))) {
    throw IoError("camera_calibration_parsers could not format the calibration of '" + camera_name +
                  "'");
  }
  return yaml.str();
}

EncoderReading fromEncoderMsg(const dtmsg::WheelEncoderStamped& msg) {
  if (msg.resolution == 0) {
    throw InputError("wheel encoder message with resolution 0 (frame '" + msg.header.frame_id +
                     "')");
  }
  EncoderReading r;
  r.stamp_s = msg.header.stamp.toSec();
  r.ticks = msg.data;
  r.ticks_per_revolution = msg.resolution;
  return r;
}

dtmsg::WheelEncoderStamped toEncoderMsg(const EncoderReading& reading,
                                        const std::string& frame_id) {
  dtmsg::WheelEncoderStamped msg;
  msg.header.stamp = toRosTime(reading.stamp_s);
  msg.header.frame_id = frame_id;
  msg.data = reading.ticks;
  msg.resolution = static_cast<uint16_t>(reading.ticks_per_revolution);
  msg.type = dtmsg::WheelEncoderStamped::ENCODER_TYPE_INCREMENTAL;
  return msg;
}

RangeReading fromRangeMsg(const sensor_msgs::Range& msg) {
  RangeReading r;
  r.stamp_s = toSeconds(msg.header.stamp);
  r.range_m = msg.range;  // float → double keeps ±inf and NaN (REP 117)
  r.min_range_m = msg.min_range;
  r.max_range_m = msg.max_range;
  return r;
}

WheelDuties fromWheelsCmd(const dtmsg::WheelsCmdStamped& msg) {
  return WheelDuties{msg.vel_left, msg.vel_right};
}

dtmsg::WheelsCmdStamped toWheelsCmd(const WheelDuties& duties, const ros::Time& stamp) {
  dtmsg::WheelsCmdStamped msg;
  msg.header.stamp = stamp;
  msg.vel_left = static_cast<float>(duties.left);
  msg.vel_right = static_cast<float>(duties.right);
  return msg;
}

wheels::CarCommand fromCarCmd(const dtmsg::Twist2DStamped& msg) {
  return wheels::CarCommand{msg.v, msg.omega};
}

dtmsg::Twist2DStamped toCarCmd(const wheels::CarCommand& cmd, const ros::Time& stamp) {
  dtmsg::Twist2DStamped msg;
  msg.header.stamp = stamp;
  msg.v = static_cast<float>(cmd.v_mps);
  msg.omega = static_cast<float>(cmd.omega_radps);
  return msg;
}

namespace {
geometry_msgs::Quaternion rotationToQuaternion(const cv::Matx33d& r) {
  // Shepperd's method: numerically safe for every rotation.
  geometry_msgs::Quaternion q;
  const double tr = r(0, 0) + r(1, 1) + r(2, 2);
  if (tr > 0) {
    const double s = 2 * std::sqrt(tr + 1);
    q.w = 0.25 * s;
    q.x = (r(2, 1) - r(1, 2)) / s;
    q.y = (r(0, 2) - r(2, 0)) / s;
    q.z = (r(1, 0) - r(0, 1)) / s;
  } else if (r(0, 0) > r(1, 1) && r(0, 0) > r(2, 2)) {
    const double s = 2 * std::sqrt(1 + r(0, 0) - r(1, 1) - r(2, 2));
    q.w = (r(2, 1) - r(1, 2)) / s;
    q.x = 0.25 * s;
    q.y = (r(0, 1) + r(1, 0)) / s;
    q.z = (r(0, 2) + r(2, 0)) / s;
  } else if (r(1, 1) > r(2, 2)) {
    const double s = 2 * std::sqrt(1 + r(1, 1) - r(0, 0) - r(2, 2));
    q.w = (r(0, 2) - r(2, 0)) / s;
    q.x = (r(0, 1) + r(1, 0)) / s;
    q.y = 0.25 * s;
    q.z = (r(1, 2) + r(2, 1)) / s;
  } else {
    const double s = 2 * std::sqrt(1 + r(2, 2) - r(0, 0) - r(1, 1));
    q.w = (r(1, 0) - r(0, 1)) / s;
    q.x = (r(0, 2) + r(2, 0)) / s;
    q.y = (r(1, 2) + r(2, 1)) / s;
    q.z = 0.25 * s;
  }
  return q;
}

cv::Matx33d quaternionToRotation(const geometry_msgs::Quaternion& q_in) {
  const double n = std::sqrt(q_in.w * q_in.w + q_in.x * q_in.x + q_in.y * q_in.y + q_in.z * q_in.z);
  if (!(n > 0) || !std::isfinite(n)) throw InputError("quaternion of zero or non-finite norm");
  const double w = q_in.w / n, x = q_in.x / n, y = q_in.y / n, z = q_in.z / n;
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}
}  // namespace

report::StatusUpdate fromStatusMsg(const autocal::CalibrationStatus& msg) {
  using State = report::StatusUpdate::State;
  report::StatusUpdate u;
  u.stamp_s = msg.header.stamp.toSec();
  u.phase = msg.phase;
  u.state = msg.state == autocal::CalibrationStatus::STATE_DONE     ? State::kDone
            : msg.state == autocal::CalibrationStatus::STATE_FAILED ? State::kFailed
            : msg.state == autocal::CalibrationStatus::STATE_IDLE   ? State::kIdle
                                                                    : State::kRunning;
  u.progress = msg.progress;
  u.text = msg.text;
  u.failure_reason = msg.failure_reason;
  u.file = msg.file;
  for (size_t i = 0; i < msg.figure_names.size() && i < msg.figure_values.size(); ++i)
    u.figures.emplace_back(msg.figure_names[i], msg.figure_values[i]);
  return u;
}

markers::TagDetection fromTagDetectionMsg(const dtmsg::AprilTagDetection& msg) {
  markers::TagDetection d;
  d.id = msg.tag_id;
  d.family = msg.tag_family;
  d.hamming = msg.hamming;
  d.decision_margin = msg.decision_margin;
  for (int i = 0; i < 9; ++i) d.homography.val[i] = msg.homography[static_cast<size_t>(i)];
  d.center_px = {msg.center[0], msg.center[1]};
  for (size_t i = 0; i < 4; ++i) d.corners_px[i] = {msg.corners[2 * i], msg.corners[2 * i + 1]};
  d.rotation = quaternionToRotation(msg.transform.rotation);
  d.translation_m = {msg.transform.translation.x, msg.transform.translation.y,
                     msg.transform.translation.z};
  d.pose_error = msg.pose_error;
  return d;
}

dtmsg::AprilTagDetection toTagDetectionMsg(const markers::TagDetection& d) {
  dtmsg::AprilTagDetection msg;
  msg.tag_id = d.id;
  msg.tag_family = d.family;
  msg.hamming = d.hamming;
  msg.decision_margin = static_cast<float>(d.decision_margin);
  for (int i = 0; i < 9; ++i)
    msg.homography[static_cast<size_t>(i)] = static_cast<float>(d.homography.val[i]);
  msg.center = {static_cast<float>(d.center_px.x), static_cast<float>(d.center_px.y)};
  for (size_t i = 0; i < 4; ++i) {
    msg.corners[2 * i] = static_cast<float>(d.corners_px[i].x);
    msg.corners[2 * i + 1] = static_cast<float>(d.corners_px[i].y);
  }
  msg.transform.rotation = rotationToQuaternion(d.rotation);
  msg.transform.translation.x = d.translation_m[0];
  msg.transform.translation.y = d.translation_m[1];
  msg.transform.translation.z = d.translation_m[2];
  msg.pose_error = static_cast<float>(d.pose_error);
  return msg;
}

geometry_msgs::Quaternion yawToQuaternion(double yaw_rad) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw_rad);
  q.w = std::cos(0.5 * yaw_rad);
  return q;
}

double quaternionToYaw(const geometry_msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

geometry_msgs::Pose toPoseMsg(const Pose2D& pose) {
  geometry_msgs::Pose p;
  p.position.x = pose.x_m;
  p.position.y = pose.y_m;
  p.orientation = yawToQuaternion(pose.yaw_rad);
  return p;
}

Pose2D fromPoseMsg(const geometry_msgs::Pose& pose) {
  return Pose2D{pose.position.x, pose.position.y, quaternionToYaw(pose.orientation)};
}

geometry_msgs::Transform toTransformMsg(const Pose2D& pose) {
  geometry_msgs::Transform t;
  t.translation.x = pose.x_m;
  t.translation.y = pose.y_m;
  t.rotation = yawToQuaternion(pose.yaw_rad);
  return t;
}

Pose2D fromTransformMsg(const geometry_msgs::Transform& t) {
  return Pose2D{t.translation.x, t.translation.y, quaternionToYaw(t.rotation)};
}

}  // namespace ros_layer
}  // namespace autocal
