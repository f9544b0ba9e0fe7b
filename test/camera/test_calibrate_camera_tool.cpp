// The calibrate_camera command end to end: image folders and bags (CompressedImage and Image) in,
// camera_info YAML and audited views out; bad input gives a clear message and a non-zero exit,
// and a failed run never touches an existing calibration file.
#include <camera_calibration_parsers/parse_yml.h>
#include <gtest/gtest.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/exit_codes.h"
#include "autocal/io/atomic_file.h"

namespace fs = std::filesystem;

namespace {

const std::string kData = "/usr/share/doc/opencv-doc/examples/data";

struct ToolRun {
  int exit_code;
  std::string output;
};

ToolRun runTool(const std::string& args) {
  const std::string cmd = std::string(AUTOCAL_TOOL) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::vector<std::string> photos() {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(kData)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("left", 0) == 0 && name.size() == 10 && e.path().extension() == ".jpg")
      out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

class ToolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("autocal_calibrate_camera_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ros::Time::init();
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

const int kBadInput = autocal::toInt(autocal::ExitCode::kBadInput);
const int kCalibrationFailed = autocal::toInt(autocal::ExitCode::kCalibrationFailed);
const double kReferenceFx = 535.9;  // OpenCV's left_intrinsics.yml for these photos

struct Written {
  std::string name;
  sensor_msgs::CameraInfo info;
};
Written readCameraInfo(const std::string& path) {
  Written w;
  std::ifstream in(path);
  EXPECT_TRUE(camera_calibration_parsers::readCalibrationYml(in, w.name, w.info)) << path;
  return w;
}

std::string board() {
  return " --board 9x6 --square 0.025 --config " + std::string(AUTOCAL_SOURCE_DIR) +
         "/config/camera_calibration.yaml";
}

}  // namespace

TEST_F(ToolTest, ImageFolderWritesCameraInfoAndViews) {
  const ToolRun r =
      runTool("--images '" + kData + "/left[0-9]*.jpg'" + board() + " --out " + path("cam.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("[13/13]"), std::string::npos) << "progress lines";
  // The camera_info YAML, read back with ROS's parsers: OpenCV's reference within 2 %.
  const Written w = readCameraInfo(path("cam.yaml"));
  EXPECT_EQ(w.name, "camera");
  EXPECT_EQ(w.info.width, 640u);
  EXPECT_EQ(w.info.height, 480u);
  EXPECT_EQ(w.info.distortion_model, "plumb_bob");
  EXPECT_NEAR(w.info.K[0], kReferenceFx, 0.02 * kReferenceFx);
  EXPECT_NEAR(w.info.K[4], kReferenceFx, 0.02 * kReferenceFx);
  EXPECT_NEAR(w.info.K[2], 320, 0.1 * 640);
  ASSERT_EQ(w.info.D.size(), 5u);
  EXPECT_LT(w.info.D[0], 0.0) << "the sample camera has barrel distortion";
  // The audit folder: one image per used view, and its corners at full precision.
  const YAML::Node views = YAML::LoadFile(path("cam_views/views.yaml"));
  EXPECT_EQ(views["board"]["inner_corners"].as<std::string>(), "9x6");
  EXPECT_DOUBLE_EQ(views["board"]["square_size_m"].as<double>(), 0.025);
  EXPECT_LT(views["rms_px"].as<double>(), 1.0);
  const YAML::Node used = views["views"];
  ASSERT_GE(used.size(), 10u);
  for (size_t i = 0; i < used.size(); ++i) {
    EXPECT_TRUE(fs::exists(path("cam_views/" + used[i]["image"].as<std::string>())));
    EXPECT_EQ(used[i]["corners"].size(), 54u);
    EXPECT_LT(used[i]["rms_px"].as<double>(), 2.0);
  }
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(path("cam_views")))
    files += e.path().extension() == ".png";
  EXPECT_EQ(files, used.size());
  // Readable by others, as the YAML beside it (a temporary folder is created 0700).
  EXPECT_EQ(fs::status(path("cam_views")).permissions() & fs::perms::all,
            fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                fs::perms::others_read | fs::perms::others_exec);

  // Again with fewer photos: the folder is replaced whole (no stale view_NNN.png), and the
  // previous YAML and folder are kept as a matching pair of .prev.
  const ToolRun again =
      runTool("--images '" + kData + "/left[01][1-8].jpg'" + board() + " --out " +
              path("cam.yaml"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const size_t used_again = YAML::LoadFile(path("cam_views/views.yaml"))["views"].size();
  EXPECT_LT(used_again, used.size());
  files = 0;
  for (const auto& e : fs::directory_iterator(path("cam_views")))
    files += e.path().extension() == ".png";
  EXPECT_EQ(files, used_again) << "stale views of the earlier run";
  EXPECT_EQ(YAML::LoadFile(path("cam_views.prev/views.yaml"))["views"].size(), used.size());
  EXPECT_DOUBLE_EQ(readCameraInfo(path("cam.yaml.prev")).info.K[0], w.info.K[0]);
}

TEST_F(ToolTest, BagsOfCompressedAndRawImages) {
  {
    rosbag::Bag bag(path("frames.bag"), rosbag::bagmode::Write);
    double t = 1.0;
    for (const std::string& f : photos()) {
      sensor_msgs::CompressedImage c;
      c.header.stamp = ros::Time(t);
      c.format = "jpeg";
      const std::string bytes = autocal::readFile(f);
      c.data.assign(bytes.begin(), bytes.end());
      bag.write("/veh/camera_node/image/compressed", c.header.stamp, c);
      const cv::Mat img = cv::imread(f, cv::IMREAD_COLOR);
      sensor_msgs::Image raw;
      raw.header.stamp = ros::Time(t);
      raw.height = static_cast<uint32_t>(img.rows);
      raw.width = static_cast<uint32_t>(img.cols);
      raw.encoding = "bgr8";
      raw.step = static_cast<uint32_t>(img.cols * 3);
      raw.data.assign(img.data, img.data + img.total() * 3);
      bag.write("/veh/camera_node/image/raw", raw.header.stamp, raw);
      t += 0.5;
    }
    std_msgs::String s;
    s.data = "not an image";
    bag.write("/chatter", ros::Time(20.0), s);
  }
  const ToolRun c =
      runTool("--bag " + path("frames.bag") + " --topic /veh/camera_node/image/compressed" +
              board() + " --out " + path("c.yaml"));
  ASSERT_EQ(c.exit_code, 0) << c.output;
  EXPECT_NEAR(readCameraInfo(path("c.yaml")).info.K[0], kReferenceFx, 0.02 * kReferenceFx);
  const ToolRun r = runTool("--bag " + path("frames.bag") + " --topic /veh/camera_node/image/raw" +
                            board() + " --out " + path("r.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // JPEG and lossless frames of the same photos: the same camera within a fraction of a pixel.
  EXPECT_NEAR(readCameraInfo(path("r.yaml")).info.K[0], readCameraInfo(path("c.yaml")).info.K[0],
              1.0);
  EXPECT_TRUE(fs::exists(path("r_views/views.yaml")));

  const ToolRun missing = runTool("--bag " + path("frames.bag") + " --topic /nope" + board() +
                                  " --out " + path("m.yaml"));
  EXPECT_EQ(missing.exit_code, kBadInput);
  EXPECT_NE(missing.output.find("no messages on topic '/nope'"), std::string::npos)
      << missing.output;
  EXPECT_NE(missing.output.find("/veh/camera_node/image/compressed"), std::string::npos)
      << missing.output;
  const ToolRun wrong = runTool("--bag " + path("frames.bag") + " --topic /chatter" + board() +
                                " --out " + path("w.yaml"));
  EXPECT_EQ(wrong.exit_code, kBadInput);
  EXPECT_NE(wrong.output.find("std_msgs/String"), std::string::npos) << wrong.output;
  EXPECT_FALSE(fs::exists(path("m.yaml")));

  // A bag damaged in the middle is bad input or damaged frames refused, never a crash or an
  // uncaught exception (internal error).
  std::string bytes = autocal::readFile(path("frames.bag"));
  for (size_t i = bytes.size() / 2; i < bytes.size() / 2 + 4096 && i < bytes.size(); ++i) {
    bytes[i] = static_cast<char>((i * 7919) & 0xff);
  }
  autocal::writeFileAtomically(path("damaged.bag"), bytes);
  const ToolRun damaged =
      runTool("--bag " + path("damaged.bag") + " --topic /veh/camera_node/image/compressed" +
              board() + " --out " + path("d.yaml"));
  EXPECT_TRUE(damaged.exit_code == 0 || damaged.exit_code == kBadInput ||
              damaged.exit_code == kCalibrationFailed)
      << damaged.exit_code << "\n"
      << damaged.output;
}

TEST_F(ToolTest, BadInputIsRefusedAndNeverOverwritesAGoodFile) {
  autocal::writeFileAtomically(path("good.yaml"), "previous good calibration\n");
  fs::create_directories(path("corrupt"));
  for (const std::string& f : photos())
    fs::copy_file(f, path("corrupt/" + fs::path(f).filename().string()));
  {
    std::ofstream bad(path("corrupt/zz_broken.jpg"));
    bad << "this is not a JPEG";
  }
  const ToolRun corrupt =
      runTool("--images '" + path("corrupt/*.jpg") + "'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(corrupt.exit_code, kBadInput);
  EXPECT_NE(corrupt.output.find("zz_broken.jpg: corrupt image: no decoder reads it"),
            std::string::npos)
      << corrupt.output;
  // A JPEG cut short decodes with a warning and grey rows, and would pass as a view with no
  // board: named as corrupt instead.
  {
    const std::string bytes = autocal::readFile(photos()[0]);
    std::ofstream(path("corrupt/zz_broken.jpg"), std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 2 / 3));
  }
  const ToolRun truncated =
      runTool("--images '" + path("corrupt/*.jpg") + "'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(truncated.exit_code, kBadInput);
  EXPECT_NE(truncated.output.find("zz_broken.jpg: corrupt image: truncated JPEG"),
            std::string::npos)
      << truncated.output;
  // A folder instead of a pattern.
  const ToolRun folder =
      runTool("--images '" + path("corrupt") + "'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(folder.exit_code, kBadInput);
  EXPECT_NE(folder.output.find("is a folder, not an image"), std::string::npos) << folder.output;

  fs::create_directories(path("mixed"));
  for (const std::string& f : photos())
    fs::copy_file(f, path("mixed/" + fs::path(f).filename().string()));
  cv::Mat small;
  cv::resize(cv::imread(photos()[0]), small, cv::Size(320, 240));
  cv::imwrite(path("mixed/small.jpg"), small);
  const ToolRun mixed =
      runTool("--images '" + path("mixed/*.jpg") + "'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(mixed.exit_code, kBadInput);
  EXPECT_NE(mixed.output.find("one calibration needs one image size"), std::string::npos)
      << mixed.output;

  const ToolRun none =
      runTool("--images '" + path("nothing/*.jpg") + "'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(none.exit_code, kBadInput);
  EXPECT_NE(none.output.find("no file matches"), std::string::npos) << none.output;

  // The wrong board size: no view at all, a calibration failure.
  const ToolRun wrong_board =
      runTool("--images '" + kData + "/left0[1-3].jpg' --board 7x5 --square 0.025 --config " +
              std::string(AUTOCAL_SOURCE_DIR) + "/config/camera_calibration.yaml --out " +
              path("good.yaml"));
  EXPECT_EQ(wrong_board.exit_code, kCalibrationFailed);
  EXPECT_NE(wrong_board.output.find("no usable view"), std::string::npos) << wrong_board.output;

  // Too few views: refused, nothing written.
  const ToolRun few =
      runTool("--images '" + kData + "/left0[1-3].jpg'" + board() + " --out " + path("good.yaml"));
  EXPECT_EQ(few.exit_code, kCalibrationFailed);
  EXPECT_NE(few.output.find("too few views"), std::string::npos) << few.output;

  // A result that fails the quality gate (here: an RMS limit no real camera meets) is reported
  // and not written.
  std::string config =
      autocal::readFile(std::string(AUTOCAL_SOURCE_DIR) + "/config/camera_calibration.yaml");
  const std::string key = "max_rms_px: 1.0";
  ASSERT_NE(config.find(key), std::string::npos);
  config.replace(config.find(key), key.size(), "max_rms_px: 0.01");
  autocal::writeFileAtomically(path("strict.yaml"), config);
  const ToolRun gate = runTool("--images '" + kData + "/left[0-9]*.jpg' --config " +
                               path("strict.yaml") + " --out " + path("good.yaml"));
  EXPECT_EQ(gate.exit_code, kCalibrationFailed);
  EXPECT_NE(gate.output.find("fails the quality gate"), std::string::npos) << gate.output;
  EXPECT_NE(gate.output.find("RMS reprojection error"), std::string::npos) << gate.output;
  EXPECT_FALSE(fs::exists(path("good_views")));

  const ToolRun usage = runTool("--images x.jpg");
  EXPECT_EQ(usage.exit_code, 64);
  // A square of 0, or one in millimetres, is no square in metres.
  for (const char* square : {"0", "25"}) {
    const ToolRun bad =
        runTool("--images x.jpg --square " + std::string(square) + " --out " + path("good.yaml"));
    EXPECT_EQ(bad.exit_code, 64) << square;
    EXPECT_NE(bad.output.find("--square: the side of a square in metres"), std::string::npos)
        << bad.output;
  }
  EXPECT_EQ(autocal::readFile(path("good.yaml")), "previous good calibration\n");
}
