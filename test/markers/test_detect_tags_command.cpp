// The detect_tags command end to end: the simulator renders floor tags from known robot poses,
// the frames go to the command as a PNG folder and as a bag (JPEG CompressedImage and raw Image),
// the camera_info holds the simulator's TRUE lens, and the printed YAML is judged against the
// simulator's truth (ids, corners, position within 1 cm, orientation within 1°). Bad input gives
// the documented exit code, a message on stderr and nothing on stdout.
#include <gtest/gtest.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "autocal/exit_codes.h"
#include "autocal/io/atomic_file.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/scene.h"
#include "autocal_ros/msg_conversion.h"

namespace fs = std::filesystem;
using namespace autocal;

namespace {

struct CommandRun {
  int exit_code = -1;
  std::string out, err;
};

CommandRun runDetectTags(const std::string& args, const fs::path& dir) {
  const std::string err_file = (dir / "stderr.txt").string();
  const std::string cmd = std::string(DETECT_TAGS_BINARY) + " " + args + " 2>" + err_file;
  FILE* p = ::popen(cmd.c_str(), "r");
  CommandRun r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

const std::string kSimConfig = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";

struct Frame {
  sim::Pose2 pose;
  cv::Mat image;  // BGR, as rendered through the true lens
};

/// The tags' truth in one frame, and the judgement of what the command printed for it.
struct Score {
  int tags = 0;              ///< tags printed
  int expected_missing = 0;  ///< tags fully in view within 0.45 m that were not printed
  int unknown_ids = 0;
  double worst_position_m = 0, worst_angle_deg = 0;
  double worst_corner_px = 0;       ///< printed corners vs the truth's, undistorted image
  double worst_consistency_px = 0;  ///< printed corners vs the printed pose reprojected
  void add(const Score& s) {
    tags += s.tags;
    expected_missing += s.expected_missing;
    unknown_ids += s.unknown_ids;
    worst_position_m = std::max(worst_position_m, s.worst_position_m);
    worst_angle_deg = std::max(worst_angle_deg, s.worst_angle_deg);
    worst_corner_px = std::max(worst_corner_px, s.worst_corner_px);
    worst_consistency_px = std::max(worst_consistency_px, s.worst_consistency_px);
  }
};

class DetectTagsCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    robot_ = new sim::RobotConfig(sim::loadRobotConfig(kSimConfig + "robot_ideal.yaml"));
    world_ = new sim::WorldConfig(sim::loadWorldConfig(kSimConfig + "world.yaml"));
    sim::RenderOptions ro;
    ro.supersampling = robot_->camera.supersampling;
    ro.noise_sigma = robot_->camera.noise_sigma;
    sim::Renderer renderer(robot_->camera, *world_, ro);
    std::mt19937_64 rng(10);
    frames_ = new std::vector<Frame>;
    // Facing the tag strip (−x) from several distances, offsets and headings: 1–6 tags in view.
    for (double x : {0.0, -0.25}) {
      for (double y : {-0.04, 0.05}) {
        for (double dyaw_deg : {-12.0, 0.0, 7.0}) {
          const sim::Pose2 pose{x, y, M_PI + dyaw_deg * M_PI / 180};
          frames_->push_back({pose, renderer.render({pose}, rng)});
        }
      }
    }
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete robot_;
    delete world_;
  }

  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("autocal_detect_tags_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "frames");
    ros::Time::init();
    writeCameraInfo("truth.yaml", robot_->camera.truth);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void writeCameraInfo(const std::string& name, const CameraIntrinsics& in) const {
    std::ofstream(path(name)) << ros_layer::cameraInfoYaml(in, "autobot");
  }

  /// Writes the frames as PNGs frame_NN.png; returns the pose of each file.
  std::map<std::string, sim::Pose2> writeFrames() const {
    std::map<std::string, sim::Pose2> poses;
    for (size_t i = 0; i < frames_->size(); ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%02zu.png", i);
      const std::string file = (dir_ / "frames" / name).string();
      EXPECT_TRUE(cv::imwrite(file, (*frames_)[i].image));
      poses[file] = (*frames_)[i].pose;
    }
    return poses;
  }

  std::string baseArgs() const {
    return "--camera-info " + path("truth.yaml") + " --tag-size 0.065";
  }

  /// Judges one printed image item against the truth of the robot at `pose`.
  Score judge(const YAML::Node& item, const sim::Pose2& pose) const {
    const CameraIntrinsics& K = robot_->camera.truth;
    const Eigen::Isometry3d world_cam = sim::cameraInWorld(robot_->camera, pose);
    const Eigen::Isometry3d cam_world = world_cam.inverse();
    // Pinhole projection in the undistorted image (same K, no distortion).
    auto project = [&](const Eigen::Vector3d& p) {
      return Eigen::Vector2d(K.fx * p.x() / p.z() + K.cx, K.fy * p.y() / p.z() + K.cy);
    };
    Score s;
    std::map<int, YAML::Node> printed;
    for (const YAML::Node& t : item["tags"]) printed[t["id"].as<int>()] = t;
    for (const auto& [id, t] : printed) {
      ++s.tags;
      const auto it = std::find_if(world_->floor_tags.begin(), world_->floor_tags.end(),
                                   [&](const sim::FloorTagConfig& f) { return f.id == id; });
      if (it == world_->floor_tags.end()) {
        ++s.unknown_ids;
        continue;
      }
      const Eigen::Isometry3d cam_tag = cam_world * sim::tagInWorld(*it);
      const Eigen::Vector3d p(t["position_m"][0].as<double>(), t["position_m"][1].as<double>(),
                              t["position_m"][2].as<double>());
      const Eigen::Quaterniond q(
          t["orientation_xyzw"][3].as<double>(), t["orientation_xyzw"][0].as<double>(),
          t["orientation_xyzw"][1].as<double>(), t["orientation_xyzw"][2].as<double>());
      s.worst_position_m = std::max(s.worst_position_m, (p - cam_tag.translation()).norm());
      const double angle =
          q.normalized().angularDistance(Eigen::Quaterniond(cam_tag.linear())) * 180 / M_PI;
      s.worst_angle_deg = std::max(s.worst_angle_deg, angle);
      const std::array<Eigen::Vector3d, 4> corners = sim::tagCorners(*it);
      const double h = 0.5 * it->size_m;
      const Eigen::Vector3d in_tag[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d c(t["corners_px"][k][0].as<double>(),
                                t["corners_px"][k][1].as<double>());
        s.worst_corner_px =
            std::max(s.worst_corner_px, (c - project(cam_world * corners[k])).norm());
        // The printed pose puts the tag's own corners where the printed corners are.
        const Eigen::Vector3d by_pose = q.normalized() * in_tag[k] + p;
        s.worst_consistency_px = std::max(s.worst_consistency_px, (c - project(by_pose)).norm());
      }
    }
    // Every tag fully in view (10 px from the edge) within 0.45 m must be found. (Farther floor
    // tags are too foreshortened to decode from 10 cm above the floor: at 0.5 m a 6.5 cm tag is
    // about 8 px high, one pixel per code cell.)
    for (const sim::FloorTagConfig& f : world_->floor_tags) {
      const Eigen::Isometry3d cam_tag = cam_world * sim::tagInWorld(f);
      if (cam_tag.translation().norm() > 0.45 || cam_tag.translation().z() <= 0) continue;
      bool inside = true;
      for (const Eigen::Vector3d& c : sim::tagCorners(f)) {
        const Eigen::Vector3d pc = cam_world * c;
        Eigen::Vector2d px;
        const sim::CameraModel model(K);
        if (!model.project(pc, &px) || px.x() < 10 || px.y() < 10 || px.x() > K.width - 10 ||
            px.y() > K.height - 10) {
          inside = false;
        }
      }
      if (inside && !printed.count(f.id)) ++s.expected_missing;
    }
    return s;
  }

  static sim::RobotConfig* robot_;
  static sim::WorldConfig* world_;
  static std::vector<Frame>* frames_;
  fs::path dir_;
};

sim::RobotConfig* DetectTagsCommand::robot_ = nullptr;
sim::WorldConfig* DetectTagsCommand::world_ = nullptr;
std::vector<Frame>* DetectTagsCommand::frames_ = nullptr;

const int kBadInput = toInt(ExitCode::kBadInput);
const int kBadConfig = toInt(ExitCode::kBadConfig);
const int kUsage = toInt(ExitCode::kUsage);

void printScore(const char* what, const Score& s, size_t frames) {
  std::cout << what << ": " << s.tags << " tags in " << frames << " frames, worst position error "
            << s.worst_position_m * 1000 << " mm, worst orientation error " << s.worst_angle_deg
            << " deg, worst corner error " << s.worst_corner_px << " px, worst pose-corner "
            << s.worst_consistency_px << " px, missed " << s.expected_missing << std::endl;
}

}  // namespace

TEST_F(DetectTagsCommand, FolderOfPngsMatchesTheSimulatorsTruth) {
  const std::map<std::string, sim::Pose2> poses = writeFrames();
  const CommandRun r = runDetectTags("--images '" + path("frames") + "/*.png' " + baseArgs(), dir_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const YAML::Node y = YAML::Load(r.out);
  ASSERT_TRUE(y.IsSequence());
  ASSERT_EQ(y.size(), poses.size());
  Score total;
  std::set<int> per_frame_counts;
  for (const YAML::Node& item : y) {
    const std::string file = item["file"].as<std::string>();
    ASSERT_TRUE(poses.count(file)) << file;
    const Score s = judge(item, poses.at(file));
    per_frame_counts.insert(s.tags);
    total.add(s);
  }
  printScore("png, no floor normal", total, y.size());
  EXPECT_GE(*per_frame_counts.begin(), 1);   // every frame has a tag
  EXPECT_GE(*per_frame_counts.rbegin(), 2);  // and some several
  EXPECT_EQ(total.unknown_ids, 0);
  EXPECT_EQ(total.expected_missing, 0);
  EXPECT_LT(total.worst_position_m, 0.01);
  EXPECT_LT(total.worst_angle_deg, 1.0);
  EXPECT_LT(total.worst_corner_px, 1.5);
  EXPECT_LT(total.worst_consistency_px, 1.0);
}

TEST_F(DetectTagsCommand, FloorNormalGivesTheSamePoses) {
  const std::map<std::string, sim::Pose2> poses = writeFrames();
  // The floor's up in the optical frame, from the true mount.
  const Eigen::Vector3d up =
      sim::cameraToRobotRotation(robot_->camera).transpose() * Eigen::Vector3d::UnitZ();
  char normal[96];
  std::snprintf(normal, sizeof normal, "%.9f,%.9f,%.9f", up.x(), up.y(), up.z());
  const CommandRun r = runDetectTags(
      "--images '" + path("frames") + "/*.png' " + baseArgs() + " --floor-normal " + normal, dir_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const YAML::Node y = YAML::Load(r.out);
  ASSERT_EQ(y.size(), poses.size());
  Score total;
  for (const YAML::Node& item : y) total.add(judge(item, poses.at(item["file"].as<std::string>())));
  printScore("png, floor normal", total, y.size());
  EXPECT_EQ(total.expected_missing, 0);
  EXPECT_LT(total.worst_position_m, 0.01);
  EXPECT_LT(total.worst_angle_deg, 1.0);
}

TEST_F(DetectTagsCommand, BagOfJpegAndRawFramesMatchesTheTruth) {
  const std::string bag_path = path("frames.bag");
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    for (size_t i = 0; i < frames_->size(); ++i) {
      const ros::Time stamp(100 + 0.5 * static_cast<double>(i));
      sensor_msgs::CompressedImage c;
      c.header.stamp = stamp;
      c.format = "jpeg";
      cv::imencode(".jpg", (*frames_)[i].image, c.data,
                   {cv::IMWRITE_JPEG_QUALITY, robot_->camera.jpeg_quality});
      bag.write("/autobot/camera_node/image/compressed", stamp, c);
      sensor_msgs::Image raw;
      raw.header.stamp = stamp;
      raw.height = 480;
      raw.width = 640;
      raw.encoding = "bgr8";
      raw.step = 640 * 3;
      const cv::Mat& m = (*frames_)[i].image;
      raw.data.assign(m.data, m.data + m.total() * m.elemSize());
      bag.write("/autobot/camera_node/image/raw", stamp, raw);
    }
    std_msgs::String s;
    s.data = "not an image";
    bag.write("/chatter", ros::Time(100), s);
  }
  for (const std::string topic :
       {"/autobot/camera_node/image/compressed", "/autobot/camera_node/image/raw"}) {
    const CommandRun r =
        runDetectTags("--bag " + bag_path + " --topic " + topic + " " + baseArgs(), dir_);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const YAML::Node y = YAML::Load(r.out);
    ASSERT_EQ(y.size(), frames_->size());
    Score total;
    for (size_t i = 0; i < y.size(); ++i) {
      EXPECT_FALSE(y[i]["file"]);
      EXPECT_NEAR(y[i]["stamp"].as<double>(), 100 + 0.5 * static_cast<double>(i), 1e-9);
      total.add(judge(y[i], (*frames_)[i].pose));
    }
    printScore(topic.c_str(), total, y.size());
    EXPECT_EQ(total.unknown_ids, 0);
    EXPECT_EQ(total.expected_missing, 0);
    EXPECT_LT(total.worst_position_m, 0.01);
    EXPECT_LT(total.worst_angle_deg, 1.0);
    EXPECT_LT(total.worst_corner_px, 1.5);
  }

  // A topic the bag does not have names the ones it has; a non-image topic is refused.
  CommandRun r = runDetectTags("--bag " + bag_path + " --topic /nope " + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("no messages on topic '/nope'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("/autobot/camera_node/image/compressed"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  r = runDetectTags("--bag " + bag_path + " --topic /chatter " + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("std_msgs/String"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  // A missing bag, and a file that is not a bag.
  r = runDetectTags("--bag " + path("missing.bag") + " --topic /t " + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("cannot open the bag"), std::string::npos) << r.err;
  std::ofstream(path("junk.bag")) << "not a bag";
  r = runDetectTags("--bag " + path("junk.bag") + " --topic /t " + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("junk.bag"), std::string::npos) << r.err;
}

TEST_F(DetectTagsCommand, BadInputGivesTheDocumentedExitCodeAndNoOutput) {
  writeFrames();
  const std::string images = "--images '" + path("frames") + "/*.png' ";
  // No file matches the glob.
  CommandRun r = runDetectTags("--images '" + path("frames") + "/*.jpg' " + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("no file matches"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  // Missing and malformed camera_info.
  r = runDetectTags(images + "--camera-info " + path("none.yaml") + " --tag-size 0.065", dir_);
  EXPECT_EQ(r.exit_code, kBadConfig);
  EXPECT_NE(r.err.find("none.yaml: cannot open the file"), std::string::npos) << r.err;
  std::ofstream(path("bad.yaml"))
      << "image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 3, "
         "cols: 3, data: [1, 2]}\n";
  r = runDetectTags(images + "--camera-info " + path("bad.yaml") + " --tag-size 0.065", dir_);
  EXPECT_EQ(r.exit_code, kBadConfig);
  EXPECT_NE(r.err.find("camera_matrix.data"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  // The camera_info is for another image size.
  CameraIntrinsics half = robot_->camera.truth;
  half.width = 320;
  half.height = 240;
  writeCameraInfo("half.yaml", half);
  r = runDetectTags(images + "--camera-info " + path("half.yaml") + " --tag-size 0.065", dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("frame_00.png: the image is 640x480 px but the camera_info is for 320x240"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out, "");
  // An image that does not decode, after good ones: named, and nothing printed.
  std::ofstream(path("frames/frame_99.png")) << "not a png";
  r = runDetectTags(images + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("frame_99.png: corrupt image: no decoder reads it"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.out, "");
  // A PNG cut short (OpenCV would decode it with a warning and grey rows): named as corrupt.
  {
    const std::string bytes = autocal::readFile(path("frames/frame_00.png"));
    std::ofstream(path("frames/frame_99.png"), std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  r = runDetectTags(images + baseArgs(), dir_);
  EXPECT_EQ(r.exit_code, kBadInput);
  EXPECT_NE(r.err.find("frame_99.png: corrupt image: truncated PNG"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  // Bad command lines and bad option values.
  r = runDetectTags(images + "--camera-info " + path("truth.yaml"), dir_);
  EXPECT_EQ(r.exit_code, kUsage);
  EXPECT_NE(r.err.find("--tag-size"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("usage: detect_tags"), std::string::npos) << r.err;
  r = runDetectTags(images + baseArgs() + " --decimate 0.5", dir_);
  EXPECT_EQ(r.exit_code, kBadConfig);
  EXPECT_NE(r.err.find("decimate"), std::string::npos) << r.err;
  r = runDetectTags("--help", dir_);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("UNDISTORTED"), std::string::npos);
}
