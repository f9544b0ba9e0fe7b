// camera_view_node (camera_view_node.test): the camera image with detections, raw, for RViz. The
// test plays the camera (JPEG frames), the wheel stage's detections and the camera stage's debug
// image, and checks camera_view/image: a frame with its detections' outline drawn (paired by stamp,
// in either order), the debug image instead while that comes, and no subscription to its inputs
// while nobody looks.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

namespace {

using autocal::dtmsg::AprilTagDetection;
using autocal::dtmsg::AprilTagDetectionArray;
using autocal::test::spinUntil;
using autocal::test::testParam;

sensor_msgs::CompressedImage jpeg(const cv::Scalar& bgr, const ros::Time& stamp) {
  const cv::Mat image(240, 320, CV_8UC3, bgr);
  sensor_msgs::CompressedImage m;
  m.header.stamp = stamp;
  m.format = "jpeg";
  cv::imencode(".jpg", image, m.data, {cv::IMWRITE_JPEG_QUALITY, 95});
  return m;
}

cv::Vec3b pixel(const sensor_msgs::Image& image, int row, int col) {
  const uint8_t* p = &image.data[row * image.step + 3 * col];
  return {p[0], p[1], p[2]};
}

std::string toString(const cv::Vec3b& p) {
  return "(" + std::to_string(p[0]) + ", " + std::to_string(p[1]) + ", " + std::to_string(p[2]) +
         ")";
}

/// |a - b| <= tol in every channel (JPEG).
bool near(const cv::Vec3b& a, const cv::Vec3b& b, int tol = 12) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(int(a[i]) - int(b[i])) > tol) return false;
  return true;
}

TEST(CameraViewNode, TheFrameWithItsDetectionsOrTheDebugImageOnlyWhileWatched) {
  ros::NodeHandle nh(testParam<std::string>("veh"));
  ros::Publisher frame_pub =
      nh.advertise<sensor_msgs::CompressedImage>("camera_node/image/compressed", 5);
  ros::Publisher debug_pub = nh.advertise<sensor_msgs::CompressedImage>(
      "camera_calibration_node/debug/image/compressed", 5);
  ros::Publisher detections_pub =
      nh.advertise<AprilTagDetectionArray>("apriltag_detector_node/detections", 5);

  // Nobody watches: the node does not subscribe to the camera.
  ASSERT_TRUE(spinUntil(
      [&] {
        ros::master::V_TopicInfo topics;
        ros::master::getTopics(topics);
        for (const auto& t : topics)
          if (t.name == nh.resolveName("camera_view/image")) return true;
        return false;
      },
      60.0))
      << "camera_view_node does not advertise camera_view/image";
  EXPECT_EQ(frame_pub.getNumSubscribers(), 0u);

  sensor_msgs::Image::ConstPtr last;
  ros::Subscriber view_sub = nh.subscribe<sensor_msgs::Image>(
      "camera_view/image", 5, [&](const sensor_msgs::Image::ConstPtr& m) { last = m; });
  ASSERT_TRUE(spinUntil(
      [&] {
        return frame_pub.getNumSubscribers() > 0 && debug_pub.getNumSubscribers() > 0 &&
               detections_pub.getNumSubscribers() > 0;
      },
      30.0))
      << "watched, the node does not subscribe to its inputs";

  // The wheel stage: a grey frame and a tag detected in it, the same stamp. Sent again (new stamps)
  // until a drawn frame comes back: the two topics may arrive in either order.
  const cv::Scalar grey(128, 128, 128);
  AprilTagDetection tag;
  tag.tag_id = 3;
  tag.transform.rotation.w = 1;
  const float corners[8] = {100, 180, 220, 180, 220, 60, 100, 60};
  std::copy(corners, corners + 8, tag.corners.begin());
  tag.center[0] = 160;
  tag.center[1] = 120;
  const auto drawn = [&] {
    return last && last->width == 320 && last->height == 240 && last->encoding == "bgr8" &&
           near(pixel(*last, 180, 160), cv::Vec3b(0, 0, 255), 40) &&
           near(pixel(*last, 120, 220), cv::Vec3b(0, 220, 0), 40);
  };
  ros::Time stamp = ros::Time::now();
  // A bad detection (a zero quaternion) is dropped; the node carries on.
  AprilTagDetectionArray bad;
  bad.header.stamp = stamp;
  bad.detections.push_back(tag);
  bad.detections.back().transform.rotation.w = 0;
  detections_pub.publish(bad);
  for (int i = 0; i < 100 && !drawn(); ++i) {
    stamp += ros::Duration(0.05);
    AprilTagDetectionArray detections;
    detections.header.stamp = stamp;
    detections.detections.push_back(tag);
    detections_pub.publish(detections);
    spinUntil([] { return false; }, 0.02);  // pacing only: the detections go first, mostly
    frame_pub.publish(jpeg(grey, stamp));
    spinUntil([&] { return drawn(); }, 0.2);
  }
  ASSERT_TRUE(drawn()) << "no frame with the tag's outline; last: "
                       << (last ? std::to_string(last->width) + "x" + std::to_string(last->height) +
                                      " " + last->encoding + ", red edge " +
                                      toString(pixel(*last, 180, 160)) + ", green edge " +
                                      toString(pixel(*last, 120, 220))
                                : std::string("none"));
  EXPECT_TRUE(near(pixel(*last, 20, 20), cv::Vec3b(128, 128, 128))) << "only the outline drawn";

  // The usual order: the frame, then the stage's detections in it (paired by stamp).
  for (int i = 0; i < 3; ++i) {
    stamp += ros::Duration(0.05);
    const ros::Time sent = stamp;
    frame_pub.publish(jpeg(grey, sent));
    spinUntil([] { return false; }, 0.05);  // pacing only: the frame goes first, mostly
    AprilTagDetectionArray detections;
    detections.header.stamp = sent;
    detections.detections.push_back(tag);
    detections_pub.publish(detections);
    ASSERT_TRUE(spinUntil([&] { return last->header.stamp == sent && drawn(); }, 10.0))
        << "frame " << i << " not shown with its detections";
  }

  // The camera stage's debug image comes first while it comes (frames keep coming too).
  const cv::Scalar blue(200, 40, 30);
  const auto debug_shown = [&] {
    return last && near(pixel(*last, 20, 20), cv::Vec3b(200, 40, 30), 20);
  };
  for (int i = 0; i < 100 && !debug_shown(); ++i) {
    stamp += ros::Duration(0.05);
    debug_pub.publish(jpeg(blue, stamp));
    frame_pub.publish(jpeg(grey, stamp));
    spinUntil([&] { return debug_shown(); }, 0.2);
  }
  ASSERT_TRUE(debug_shown()) << "the debug image is not shown";
  for (int i = 0; i < 5; ++i) {
    stamp += ros::Duration(0.05);
    debug_pub.publish(jpeg(blue, stamp));
    frame_pub.publish(jpeg(grey, stamp));
    const ros::Time sent = stamp;
    ASSERT_TRUE(spinUntil([&] { return last->header.stamp == sent; }, 10.0));
    EXPECT_TRUE(debug_shown()) << "a camera frame replaced the debug image";
  }

  // Nobody watches again: the node lets go of its inputs.
  view_sub.shutdown();
  EXPECT_TRUE(spinUntil([&] { return frame_pub.getNumSubscribers() == 0; }, 30.0));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_camera_view_node");
  return RUN_ALL_TESTS();
}
