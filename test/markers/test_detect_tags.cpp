// The detect_tags command's core without images: its options, its YAML (read back with yaml-cpp),
// the quaternion, and the ROS-free camera_info reader.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <opencv2/calib3d.hpp>

#include "autocal/errors.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/markers/detect_tags.h"

using namespace autocal;
using namespace autocal::markers;

namespace {

DetectTagsArgs parse(std::vector<std::string> args) { return parseDetectTagsArgs(args); }

const char* kCameraInfo = R"(image_width: 640
image_height: 480
camera_name: autobot
camera_matrix:
  rows: 3
  cols: 3
  data: [318.0, 0, 325.4, 0, 320.5, 236.8, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.27, 0.065, 0.0011, -0.0007, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [300, 0, 320, 0, 0, 300, 240, 0, 0, 0, 1, 0]
)";

}  // namespace

TEST(DetectTagsArgs, DefaultsAreTheDetectorsAndEveryOptionIsRead) {
  const DetectTagsArgs d =
      parse({"--images", "a/*.png", "--camera-info", "c.yaml", "--tag-size", "0.065"});
  const TagDetectorOptions defaults;
  EXPECT_EQ(d.images, "a/*.png");
  EXPECT_EQ(d.camera_info, "c.yaml");
  EXPECT_DOUBLE_EQ(d.detector.tag_size_m, 0.065);
  EXPECT_EQ(d.detector.decimate, defaults.decimate);
  EXPECT_EQ(d.detector.threads, defaults.threads);
  EXPECT_EQ(d.detector.max_hamming, defaults.max_hamming);
  EXPECT_EQ(d.detector.min_decision_margin, defaults.min_decision_margin);
  EXPECT_EQ(d.detector.refine_edges, defaults.refine_edges);
  EXPECT_FALSE(d.have_floor_normal);

  const DetectTagsArgs a = parse({"--bag",
                                  "f.bag",
                                  "--topic",
                                  "/t",
                                  "--camera-info",
                                  "c.yaml",
                                  "--tag-size",
                                  "0.1",
                                  "--decimate",
                                  "2",
                                  "--threads",
                                  "3",
                                  "--max-hamming",
                                  "1",
                                  "--min-decision-margin",
                                  "35.5",
                                  "--refine-edges",
                                  "0",
                                  "--floor-normal",
                                  "0,-0.9,-0.3"});
  EXPECT_EQ(a.bag, "f.bag");
  EXPECT_EQ(a.topic, "/t");
  EXPECT_DOUBLE_EQ(a.detector.tag_size_m, 0.1);
  EXPECT_EQ(a.detector.decimate, 2.0);
  EXPECT_EQ(a.detector.threads, 3);
  EXPECT_EQ(a.detector.max_hamming, 1);
  EXPECT_EQ(a.detector.min_decision_margin, 35.5);
  EXPECT_FALSE(a.detector.refine_edges);
  ASSERT_TRUE(a.have_floor_normal);
  EXPECT_EQ(a.floor_normal, cv::Vec3d(0, -0.9, -0.3));
  EXPECT_TRUE(parse({"--help"}).help);
}

TEST(DetectTagsArgs, BadCommandLinesAreUsageErrors) {
  const std::vector<std::string> ok = {"--images", "x", "--camera-info", "c", "--tag-size", "1"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> v = ok;
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
  };
  EXPECT_THROW(parse({"--camera-info", "c", "--tag-size", "1"}), UsageError);  // no input
  EXPECT_THROW(parse(with({"--bag", "b", "--topic", "t"})), UsageError);       // both inputs
  EXPECT_THROW(parse({"--bag", "b", "--camera-info", "c", "--tag-size", "1"}), UsageError);
  EXPECT_THROW(parse({"--images", "x", "--tag-size", "1"}), UsageError);     // no camera-info
  EXPECT_THROW(parse({"--images", "x", "--camera-info", "c"}), UsageError);  // no tag size
  EXPECT_THROW(parse(with({"--tag-size", "6.5cm"})), UsageError);
  EXPECT_THROW(parse(with({"--threads", "1.5"})), UsageError);
  EXPECT_THROW(parse(with({"--refine-edges", "yes"})), UsageError);
  EXPECT_THROW(parse(with({"--floor-normal", "0,1"})), UsageError);
  EXPECT_THROW(parse(with({"--floor-normal", "0,0,0"})), UsageError);
  EXPECT_THROW(parse(with({"--bogus", "1"})), UsageError);
  EXPECT_THROW(parse(with({"--decimate"})), UsageError);
  EXPECT_THROW(parse(with({"stray"})), UsageError);
}

TEST(DetectTagsYaml, ReadsBackWithTheValuesAndDigitsPrinted) {
  TagDetection t;
  t.id = 7;
  t.hamming = 1;
  t.decision_margin = 87.654321;
  t.corners_px = {cv::Point2d(100.12345, 200.5), cv::Point2d(150, 200.25),
                  cv::Point2d(150.0004, 150), cv::Point2d(100, 150)};
  cv::Rodrigues(cv::Vec3d(0.3, -0.2, 0.1), t.rotation);
  t.translation_m = {0.0123456789, -0.05, 0.4567891};
  TagDetection failed = t;
  failed.id = 8;
  failed.pose_error = std::numeric_limits<double>::infinity();
  ImageTags a;
  a.file = "dir/we\"ird name.png";
  a.tags = {t, failed};
  ImageTags b;
  b.file = "dir/empty.png";
  ImageTags c;
  c.stamp_s = 1700000000.123456789;
  const std::string text = tagsYaml({a, b, c});
  const YAML::Node y = YAML::Load(text);
  ASSERT_TRUE(y.IsSequence()) << text;
  ASSERT_EQ(y.size(), 3u);
  EXPECT_EQ(y[0]["file"].as<std::string>(), a.file);
  EXPECT_FALSE(y[0]["stamp"]);
  const YAML::Node tag = y[0]["tags"][0];
  EXPECT_EQ(tag["id"].as<int>(), 7);
  EXPECT_EQ(tag["hamming"].as<int>(), 1);
  EXPECT_NEAR(tag["decision_margin"].as<double>(), 87.654, 1e-9);
  ASSERT_EQ(tag["corners_px"].size(), 4u);
  EXPECT_NEAR(tag["corners_px"][0][0].as<double>(), 100.123, 1e-9);
  EXPECT_NEAR(tag["corners_px"][2][0].as<double>(), 150.0, 1e-9);
  EXPECT_NEAR(tag["corners_px"][1][1].as<double>(), 200.25, 1e-9);
  EXPECT_NEAR(tag["position_m"][0].as<double>(), 0.0123457, 1e-12);
  EXPECT_NEAR(tag["position_m"][2].as<double>(), 0.456789, 1e-12);
  // The quaternion is the rotation's (to the 6 digits printed).
  cv::Vec4d q;
  for (int i = 0; i < 4; ++i) q[i] = tag["orientation_xyzw"][i].as<double>();
  EXPECT_NEAR(cv::norm(q), 1.0, 1e-5);
  const cv::Vec3d axis = cv::Vec3d(0.3, -0.2, 0.1) / cv::norm(cv::Vec3d(0.3, -0.2, 0.1));
  const double angle = cv::norm(cv::Vec3d(0.3, -0.2, 0.1));
  EXPECT_NEAR(q[3], std::cos(angle / 2), 1e-5);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(q[i], axis[i] * std::sin(angle / 2), 1e-5);
  EXPECT_TRUE(y[0]["tags"][1]["position_m"].IsNull());
  EXPECT_TRUE(y[1]["tags"].IsSequence());
  EXPECT_EQ(y[1]["tags"].size(), 0u);
  EXPECT_NEAR(y[2]["stamp"].as<double>(), c.stamp_s, 1e-6);
  EXPECT_NE(text.find("stamp: 1700000000.123456"), std::string::npos) << text;
  EXPECT_EQ(tagsYaml({}), "[]\n");
}

TEST(DetectTagsYaml, QuaternionOfEveryBranchRoundTrips) {
  // Rotations near 0, π about each axis and in between exercise the four branches.
  for (const cv::Vec3d& r : {cv::Vec3d(0, 0, 0), cv::Vec3d(3.1, 0, 0), cv::Vec3d(0, 3.1, 0.1),
                             cv::Vec3d(0.1, 0, 3.1), cv::Vec3d(1, -2, 0.5)}) {
    cv::Matx33d R;
    cv::Rodrigues(r, R);
    const cv::Vec4d q = quaternionXyzw(R);
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const cv::Matx33d back(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                           2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                           2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y));
    EXPECT_LT(cv::norm(back - R), 1e-12) << r;
    EXPECT_GE(w, 0);
  }
}

TEST(CameraInfoFile, ReadsTheRosFormat) {
  const CameraIntrinsics in = parseCameraInfoYaml(kCameraInfo, "c.yaml");
  EXPECT_EQ(in.width, 640);
  EXPECT_EQ(in.height, 480);
  EXPECT_EQ(in.fx, 318.0);
  EXPECT_EQ(in.fy, 320.5);
  EXPECT_EQ(in.cx, 325.4);
  EXPECT_EQ(in.cy, 236.8);
  EXPECT_EQ(in.distortion_model, DistortionModel::kPlumbBob);
  EXPECT_EQ(in.distortion_coefficients, (std::vector<double>{-0.27, 0.065, 0.0011, -0.0007, 0}));
}

TEST(CameraInfoFile, MalformedFilesAreConfigErrorsNamingTheKey) {
  auto message = [](const std::string& text) {
    try {
      parseCameraInfoYaml(text, "c.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto replaced = [](const std::string& from, const std::string& to) {
    std::string s = kCameraInfo;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  EXPECT_NE(message(replaced("image_width: 640", "")).find("image_width"), std::string::npos);
  EXPECT_NE(message(replaced("318.0, 0, 325.4, ", "")).find("camera_matrix.data"),
            std::string::npos);
  EXPECT_NE(message(replaced("318.0", "-318")).find("fx"), std::string::npos);
  EXPECT_NE(message(replaced("plumb_bob", "banana")).find("distortion_model"), std::string::npos);
  EXPECT_NE(message(replaced("cols: 5\n  data: [-0.27,", "cols: 6\n  data: [1, -0.27,"))
                .find("distortion_coefficients"),
            std::string::npos);
  EXPECT_NE(message("[1, 2]").find("c.yaml"), std::string::npos);
  EXPECT_NE(message("a: [").find("not valid YAML"), std::string::npos);
  EXPECT_THROW(loadCameraInfoYaml("/nonexistent/camera.yaml"), ConfigError);
}
