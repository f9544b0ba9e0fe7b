#include "autocal/markers/detect_tags.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"

namespace autocal {
namespace markers {

const char* const kDetectTagsUsage =
    "usage: detect_tags (--images 'GLOB' | --bag FILE --topic TOPIC) --camera-info FILE.yaml\n"
    "                   --tag-size EDGE_m [--decimate 1] [--threads 1] [--max-hamming 0]\n"
    "                   [--min-decision-margin 20] [--refine-edges 1] [--floor-normal x,y,z]\n"
    "  Detects tag36h11 AprilTags and prints YAML on stdout: per image its file (or the bag\n"
    "  message's stamp) and tags: id, hamming, decision_margin, corners_px (lb, rb, rt, lt),\n"
    "  position_m and orientation_xyzw of the tag in the camera optical frame (x right, y down,\n"
    "  z forward; the tag's z points into the tag).\n"
    "  Each image is UNDISTORTED with the camera_info first: corners_px are pixels of the\n"
    "  undistorted image (same camera matrix K, no distortion), not of the raw image.\n"
    "  --topic: sensor_msgs/CompressedImage or sensor_msgs/Image.\n"
    "  --tag-size: edge of the black square [m] (Duckietown: 0.065).\n"
    "  --floor-normal: the floor's up direction in the optical frame; a tag seen nearly frontally\n"
    "  has two poses that fit (IPPE's ambiguity): without it the one with the smaller\n"
    "  reprojection error is printed, with it the one lying flat on that floor.\n"
    "  Nothing is printed on stdout unless every image was read: an image that cannot be read or\n"
    "  decoded, or whose size is not the camera_info's, stops the command (exit 2).\n"
    "  Exit codes: 0 ok, 2 bad input (images, bag, topic), 3 bad camera_info or option value,\n"
    "  64 bad command line.\n";

namespace {

cv::Vec3d parseVector(const std::string& flag, const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(parseNumberArg(flag, item));
  if (v.size() != 3) throw UsageError(flag + ": expected x,y,z, got '" + text + "'");
  const cv::Vec3d n(v[0], v[1], v[2]);
  if (cv::norm(n) < 1e-9) throw UsageError(flag + ": the normal must not be zero");
  return n;
}

/// A YAML double-quoted scalar.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

DetectTagsArgs parseDetectTagsArgs(const std::vector<std::string>& args) {
  DetectTagsArgs a;
  bool have_tag_size = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "-h" || flag == "--help") {
      a.help = true;
      continue;
    }
    if (flag.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + flag + "'");
    if (i + 1 >= args.size()) throw UsageError(flag + ": missing value (or unknown option)");
    const std::string& value = args[++i];
    if (flag == "--images") {
      a.images = value;
    } else if (flag == "--bag") {
      a.bag = value;
    } else if (flag == "--topic") {
      a.topic = value;
    } else if (flag == "--camera-info") {
      a.camera_info = value;
    } else if (flag == "--tag-size") {
      a.detector.tag_size_m = parseNumberArg(flag, value);
      have_tag_size = true;
    } else if (flag == "--decimate") {
      a.detector.decimate = parseNumberArg(flag, value);
    } else if (flag == "--threads") {
      a.detector.threads = parseIntArg(flag, value);
    } else if (flag == "--max-hamming") {
      a.detector.max_hamming = parseIntArg(flag, value);
    } else if (flag == "--min-decision-margin") {
      a.detector.min_decision_margin = parseNumberArg(flag, value);
    } else if (flag == "--refine-edges") {
      if (value != "0" && value != "1") throw UsageError(flag + ": expected 0 or 1");
      a.detector.refine_edges = value == "1";
    } else if (flag == "--floor-normal") {
      a.floor_normal = parseVector(flag, value);
      a.have_floor_normal = true;
    } else {
      throw UsageError("unknown option " + flag);
    }
  }
  if (a.help) return a;
  if (a.images.empty() == a.bag.empty()) throw UsageError("give exactly one of --images and --bag");
  if (!a.bag.empty() && a.topic.empty()) throw UsageError("--bag needs --topic");
  if (a.bag.empty() && !a.topic.empty()) throw UsageError("--topic goes with --bag");
  if (a.camera_info.empty()) throw UsageError("--camera-info FILE.yaml is required");
  if (!have_tag_size) throw UsageError("--tag-size (edge of the black square, metres) is required");
  return a;
}

cv::Vec4d quaternionXyzw(const cv::Matx33d& R) {
  // Shepperd's method: divide by the largest of the four candidates.
  double x, y, z, w;
  const double tr = R(0, 0) + R(1, 1) + R(2, 2);
  if (tr > 0) {
    const double s = 2 * std::sqrt(1 + tr);
    w = 0.25 * s;
    x = (R(2, 1) - R(1, 2)) / s;
    y = (R(0, 2) - R(2, 0)) / s;
    z = (R(1, 0) - R(0, 1)) / s;
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    const double s = 2 * std::sqrt(1 + R(0, 0) - R(1, 1) - R(2, 2));
    w = (R(2, 1) - R(1, 2)) / s;
    x = 0.25 * s;
    y = (R(0, 1) + R(1, 0)) / s;
    z = (R(0, 2) + R(2, 0)) / s;
  } else if (R(1, 1) > R(2, 2)) {
    const double s = 2 * std::sqrt(1 + R(1, 1) - R(0, 0) - R(2, 2));
    w = (R(0, 2) - R(2, 0)) / s;
    x = (R(0, 1) + R(1, 0)) / s;
    y = 0.25 * s;
    z = (R(1, 2) + R(2, 1)) / s;
  } else {
    const double s = 2 * std::sqrt(1 + R(2, 2) - R(0, 0) - R(1, 1));
    w = (R(1, 0) - R(0, 1)) / s;
    x = (R(0, 2) + R(2, 0)) / s;
    y = (R(1, 2) + R(2, 1)) / s;
    z = 0.25 * s;
  }
  cv::Vec4d q(x, y, z, w);
  q /= cv::norm(q);
  if (q[3] < 0) q = -q;
  return q;
}

std::string imageTagsYaml(const ImageTags& image) {
  std::ostringstream y;
  if (!image.file.empty()) {
    y << "- file: " << quoted(image.file) << "\n";
  } else {
    y << "- stamp: " << fixed(image.stamp_s, 9) << "\n";
  }
  if (image.tags.empty()) {
    y << "  tags: []\n";
    return y.str();
  }
  y << "  tags:\n";
  const auto num = [](double v) { return formatNumber(v, 6); };
  for (const TagDetection& t : image.tags) {
    y << "    - id: " << t.id << "\n";
    y << "      hamming: " << t.hamming << "\n";
    y << "      decision_margin: " << fixed(t.decision_margin, 3) << "\n";
    y << "      corners_px: [";
    for (size_t k = 0; k < t.corners_px.size(); ++k) {
      y << (k ? ", " : "") << "[" << fixed(t.corners_px[k].x, 3) << ", "
        << fixed(t.corners_px[k].y, 3) << "]";
    }
    y << "]\n";
    if (!std::isfinite(t.pose_error)) {
      y << "      position_m: null\n      orientation_xyzw: null\n";
      continue;
    }
    const cv::Vec3d& p = t.translation_m;
    const cv::Vec4d q = quaternionXyzw(t.rotation);
    y << "      position_m: [" << num(p[0]) << ", " << num(p[1]) << ", " << num(p[2]) << "]\n";
    y << "      orientation_xyzw: [" << num(q[0]) << ", " << num(q[1]) << ", " << num(q[2]) << ", "
      << num(q[3]) << "]\n";
  }
  return y.str();
}

std::string tagsYaml(const std::vector<ImageTags>& images) {
  if (images.empty()) return "[]\n";
  std::string out;
  for (const ImageTags& image : images) out += imageTagsYaml(image);
  return out;
}

std::vector<std::string> globImageFiles(const std::string& pattern) {
  glob_t g;
  std::vector<std::string> files;
  if (::glob(pattern.c_str(), 0, nullptr, &g) == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) files.push_back(g.gl_pathv[i]);
  }
  globfree(&g);
  if (files.empty()) throw InputError("--images '" + pattern + "': no file matches");
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<TagDetection> detectTagsInImage(const cv::Mat& image, const std::string& name,
                                            const TagDetector& detector) {
  const CameraIntrinsics& in = detector.undistorter().intrinsics();
  if (image.size() != in.imageSize()) {
    throw InputError(name + ": the image is " + std::to_string(image.cols) + "x" +
                     std::to_string(image.rows) + " px but the camera_info is for " +
                     std::to_string(in.width) + "x" + std::to_string(in.height) + " px");
  }
  return detector.detect(image);
}

std::vector<ImageTags> detectTagsInFiles(const std::vector<std::string>& files,
                                         const TagDetector& detector) {
  std::vector<ImageTags> out;
  for (const std::string& file : files) {
    // Grey: libapriltag detects on grey (and it decodes faster).
    const cv::Mat image = readImageFile(file, cv::IMREAD_GRAYSCALE);
    ImageTags t;
    t.file = file;
    t.tags = detectTagsInImage(image, file, detector);
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace markers
}  // namespace autocal
