// detect_tags: AprilTags (tag36h11) and their poses on images or a bag, printed as YAML.
//   rosrun autocal detect_tags --images 'DIR/*.png' --camera-info FILE.yaml --tag-size 0.065
//   rosrun autocal detect_tags --bag FILE.bag --topic /veh/camera_node/image/compressed ...
// The images are undistorted with the camera_info first (markers::TagDetector). Needs no master.
// doc/nodes/detect_tags.md; exit codes: the one table of doc/calibration_run.md "Exit codes"
// (autocal/exit_codes.h).
#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdio>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/io/image_file.h"
#include "autocal/markers/detect_tags.h"

using namespace autocal;
using namespace autocal::markers;

namespace {

/// The header stamp, or the bag's record time when the header has none.
double stampOf(const rosbag::MessageInstance& m, const ros::Time& header_stamp) {
  return header_stamp.isZero() ? m.getTime().toSec() : header_stamp.toSec();
}

std::vector<ImageTags> detectTagsInBag(const std::string& path, const std::string& topic,
                                       const TagDetector& detector) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError(path + ": cannot open the bag: " + e.what());
  }
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  if (view.size() == 0) {
    std::set<std::string> topics;
    rosbag::View all(bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections())
      topics.insert(c->topic + " (" + c->datatype + ")");
    std::string list;
    for (const auto& t : topics) list += "\n  " + t;
    throw InputError(path + ": no messages on topic '" + topic +
                     "'; the bag has:" + (list.empty() ? " nothing" : list));
  }
  std::vector<ImageTags> out;
  try {
    for (const rosbag::MessageInstance& m : view) {
      ImageTags t;
      cv::Mat image;
      std::string cut;  // why a compressed frame is cut short
      if (auto c = m.instantiate<sensor_msgs::CompressedImage>()) {
        t.stamp_s = stampOf(m, c->header.stamp);
        cut = truncatedImage(c->data);
        if (!c->data.empty() && cut.empty()) image = cv::imdecode(c->data, cv::IMREAD_GRAYSCALE);
      } else if (auto r = m.instantiate<sensor_msgs::Image>()) {
        t.stamp_s = stampOf(m, r->header.stamp);
        try {
          image = cv_bridge::toCvCopy(r, "mono8")->image;
        } catch (const cv_bridge::Exception&) {
        }
      } else {
        throw InputError(path + ": topic '" + topic + "' carries " + m.getDataType() +
                         ", not sensor_msgs/CompressedImage or sensor_msgs/Image");
      }
      char name[200];
      std::snprintf(name, sizeof name, "%s: %s at stamp %.9f", path.c_str(), topic.c_str(),
                    t.stamp_s);
      if (!cut.empty()) throw InputError(std::string(name) + ": corrupt image: " + cut);
      if (image.empty()) throw InputError(std::string(name) + ": cannot decode the image");
      t.tags = detectTagsInImage(image, name, detector);
      out.push_back(std::move(t));
    }
  } catch (const ros::Exception& e) {
    throw InputError(path + ": the bag is corrupt or truncated after " +
                     std::to_string(out.size()) + " frames: " + e.what());
  }
  return out;
}

int run(const std::vector<std::string>& argv) {
  const DetectTagsArgs args = parseDetectTagsArgs(argv);
  if (args.help) {
    std::cout << kDetectTagsUsage;
    return 0;
  }
  const CameraIntrinsics intrinsics = loadCameraInfoYaml(args.camera_info);
  TagDetector detector(args.detector, intrinsics);
  if (args.have_floor_normal) detector.setFloorNormal(args.floor_normal);
  // Everything is detected before anything is printed: stdout holds the whole YAML or nothing.
  const std::vector<ImageTags> images =
      args.bag.empty() ? detectTagsInFiles(globImageFiles(args.images), detector)
                       : detectTagsInBag(args.bag, args.topic, detector);
  std::cout << tagsYaml(images) << std::flush;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return runCommand(
      "detect_tags", [&] { return run(args); }, kDetectTagsUsage);
}
