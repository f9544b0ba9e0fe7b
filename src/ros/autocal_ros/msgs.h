// The Duckietown message types the nodes use. On a Duckiebot, where duckietown_msgs is in the
// workspace, the real types are used (rospy publishers there compare the type NAME, not only the
// md5); elsewhere autocal's own definitions in msg/, which have the same fields and md5 sums.
#pragma once

#include <autocal/CalibrationStatus.h>

#ifdef AUTOCAL_HAVE_DUCKIETOWN_MSGS
#include <duckietown_msgs/AprilTagDetectionArray.h>
#include <duckietown_msgs/Twist2DStamped.h>
#include <duckietown_msgs/WheelEncoderStamped.h>
#include <duckietown_msgs/WheelsCmdStamped.h>
namespace autocal {
namespace dtmsg = ::duckietown_msgs;
}  // namespace autocal
#else
#include <autocal/AprilTagDetectionArray.h>
#include <autocal/Twist2DStamped.h>
#include <autocal/WheelEncoderStamped.h>
#include <autocal/WheelsCmdStamped.h>
namespace autocal {
namespace dtmsg = ::autocal;
}  // namespace autocal
#endif
