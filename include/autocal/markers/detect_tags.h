// The core of the `detect_tags` command (doc/nodes/detect_tags.md): its options, the images it
// reads, and the YAML it prints; ROS-free (the bag reading lives in the command).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/markers/tag_detection.h"
#include "autocal/markers/tag_detector.h"

namespace autocal {
namespace markers {

/// The command line's usage text (also printed after a UsageError).
extern const char* const kDetectTagsUsage;

struct DetectTagsArgs {
  std::string images;       ///< a glob of image files (exclusive with bag)
  std::string bag, topic;   ///< a bag and its sensor_msgs/CompressedImage or Image topic
  std::string camera_info;  ///< camera_info YAML (camera_calibration_parsers format)
  /// --tag-size (required: every distance scales with it), --decimate, --threads, --max-hamming,
  /// --min-decision-margin, --refine-edges; the rest as TagDetectorOptions' defaults.
  TagDetectorOptions detector;
  bool have_floor_normal = false;
  cv::Vec3d floor_normal{0, 0, 0};  ///< --floor-normal x,y,z: the floor's up in the optical frame
  bool help = false;
};

/// Parses the arguments after the program name. Throws UsageError for an unknown option, a
/// missing or malformed value, or a missing required option (not when --help is given).
DetectTagsArgs parseDetectTagsArgs(const std::vector<std::string>& args);

/// The tags found on one image (a file, or a bag message with its stamp).
struct ImageTags {
  std::string file;    ///< the image file; empty for a bag message
  double stamp_s = 0;  ///< the bag message's header stamp [s] (when file is empty)
  std::vector<TagDetection> tags;
};

/// One item of the command's YAML list: `- file: "..."` (or `- stamp: s`) and `tags:` with, per
/// tag, id, hamming, decision_margin, corners_px (lb, rb, rt, lt; 3 decimals), position_m and
/// orientation_xyzw of the tag in the camera optical frame (6 significant digits; null when the
/// pose fit failed).
std::string imageTagsYaml(const ImageTags& image);

/// The whole YAML document: the items in order ("[]" when there are none).
std::string tagsYaml(const std::vector<ImageTags>& images);

/// The unit quaternion (x, y, z, w) of a rotation matrix, w >= 0.
cv::Vec4d quaternionXyzw(const cv::Matx33d& rotation);

/// The files matching a glob, sorted. Throws InputError when none does.
std::vector<std::string> globImageFiles(const std::string& pattern);

/// Reads and detects every file in order. Throws InputError naming the file that cannot be read
/// or decoded, or whose size is not the intrinsics' size.
std::vector<ImageTags> detectTagsInFiles(const std::vector<std::string>& files,
                                         const TagDetector& detector);

/// Detects on one decoded image; `name` is used in the InputError for a wrong size.
std::vector<TagDetection> detectTagsInImage(const cv::Mat& image, const std::string& name,
                                            const TagDetector& detector);

}  // namespace markers
}  // namespace autocal
