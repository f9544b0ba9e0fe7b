// Every conversion between ROS messages and the core's types, in one place (as cartographer_ros's
// msg_conversion): nodes never convert by hand. Each function has a test in
// test/ros/test_msg_conversion.cpp.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Transform.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Range.h>

#include <string>

#include "autocal/camera_intrinsics.h"
#include "autocal/markers/tag_detection.h"
#include "autocal/pose2d.h"
#include "autocal/report/run_record.h"
#include "autocal/sensors.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msgs.h"

namespace autocal {
namespace ros_layer {

// --- time
double toSeconds(const ros::Time& stamp);
ros::Time toRosTime(double stamp_s);

// --- camera
/// camera_info of the intrinsics: K, D, R = I and P as ROS camera_calibration writes it for a
/// monocular camera (the new camera matrix of the rectified image with alpha 0: only valid
/// pixels). Header left empty.
sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& intrinsics);
/// The intrinsics of a camera_info (K and D; P and R are not needed). Throws InputError for an
/// unknown distortion model, a wrong number of coefficients, a zero size or a non-finite K.
CameraIntrinsics fromCameraInfo(const sensor_msgs::CameraInfo& info);
/// The intrinsics in a camera calibration file (camera_calibration_parsers' YAML or INI). Throws
/// ConfigError "the camera intrinsics '<path>' cannot be read (<why>)" when it cannot be read or
/// has no focal length.
CameraIntrinsics readIntrinsicsFile(const std::string& path, const std::string& why);
/// The camera_info YAML text of ROS (camera_calibration_parsers), as `camera_intrinsic/<veh>.yaml`
/// holds it. Throws IoError when the parsers refuse.
std::string cameraInfoYaml(const CameraIntrinsics& intrinsics, const std::string& camera_name);

// --- wheels
/// Throws InputError for a resolution of 0 (the reading cannot be turned into an angle).
EncoderReading fromEncoderMsg(const dtmsg::WheelEncoderStamped& msg);
dtmsg::WheelEncoderStamped toEncoderMsg(const EncoderReading& reading, const std::string& frame_id);
RangeReading fromRangeMsg(const sensor_msgs::Range& msg);
WheelDuties fromWheelsCmd(const dtmsg::WheelsCmdStamped& msg);
dtmsg::WheelsCmdStamped toWheelsCmd(const WheelDuties& duties, const ros::Time& stamp);
/// v and omega as they are (a non-finite value is the caller's to refuse).
wheels::CarCommand fromCarCmd(const dtmsg::Twist2DStamped& msg);
dtmsg::Twist2DStamped toCarCmd(const wheels::CarCommand& cmd, const ros::Time& stamp);

// --- the run
/// A calibration/status message as the report and the replay keep it.
report::StatusUpdate fromStatusMsg(const autocal::CalibrationStatus& msg);

// --- markers
markers::TagDetection fromTagDetectionMsg(const dtmsg::AprilTagDetection& msg);
dtmsg::AprilTagDetection toTagDetectionMsg(const markers::TagDetection& detection);

// --- planar poses (z = 0, rotation about z only)
geometry_msgs::Quaternion yawToQuaternion(double yaw_rad);
/// The yaw of a quaternion (its rotation about z; roll and pitch are ignored).
double quaternionToYaw(const geometry_msgs::Quaternion& q);
geometry_msgs::Pose toPoseMsg(const Pose2D& pose);
Pose2D fromPoseMsg(const geometry_msgs::Pose& pose);
geometry_msgs::Transform toTransformMsg(const Pose2D& pose);
Pose2D fromTransformMsg(const geometry_msgs::Transform& transform);

}  // namespace ros_layer
}  // namespace autocal
