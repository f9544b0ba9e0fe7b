// `calibrate_extrinsics` end to end: a rendered image of Duckietown's board and the camera_info
// of the true lens in, camera_extrinsic YAML out, judged by the simulator's truth; and the
// failures a user meets, each with its exit status and nothing written.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/atomic_file.h"
#include "autocal/sim/floor_truth.h"
#include "autocal/sim/renderer.h"

namespace {

namespace fs = std::filesystem;
using namespace autocal;

const std::string kConfigDir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";

struct ToolRun {
  int code = -1;
  std::string output;
};

ToolRun tool(const std::string& args, const fs::path& dir) {
  const fs::path log = dir / "tool.log";
  const std::string cmd = std::string(AUTOCAL_TOOL) + " " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  ToolRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.output = readFile(log.string());
  std::cout << "$ calibrate_extrinsics " << args << "\n" << r.output;
  return r;
}

class CalibrateExtrinsicsTool : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("autocal_extrinsics_tool_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    robot_ = sim::loadRobotConfig(kConfigDir + "robot_ideal.yaml");
    robot_.camera.roll_rad = 0.02;
    robot_.camera.yaw_rad = -0.03;
    camera_ = sim::trueCameraInfo(robot_);
    writeFileAtomically((dir_ / "camera.yaml").string(), sim::cameraInfoYaml(camera_));
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path render(const sim::WorldConfig& world, const std::string& name) {
    sim::RenderOptions o;
    o.supersampling = robot_.camera.supersampling;
    o.noise_sigma = robot_.camera.noise_sigma;
    sim::Renderer renderer(robot_.camera, world, o);
    std::mt19937_64 rng(3);
    const fs::path p = dir_ / name;
    cv::imwrite(p.string(), renderer.render({world.robot_start}, rng));
    return p;
  }

  fs::path dir_;
  sim::RobotConfig robot_;
  extrinsics::CameraInfoRectification camera_;
};

TEST_F(CalibrateExtrinsicsTool, WritesDuckietownsFileWithinFiveMillimetresAndKeepsThePrevious) {
  const fs::path image =
      render(sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml"), "b.png");
  const fs::path out = dir_ / "camera_extrinsic" / "robot.yaml";
  const std::string args = "--image " + image.string() + " --camera-info " +
                           (dir_ / "camera.yaml").string() + " --out " + out.string();
  const ToolRun r = tool(args, dir_);
  ASSERT_EQ(r.code, 0) << r.output;
  const Eigen::Matrix3d H = extrinsics::readHomography(out.string());
  const sim::FloorError e = sim::floorError(robot_, camera_.rectified, H);
  std::printf("floor: %.2f mm RMS, %.2f mm worst over %d points\n", 1e3 * e.rms_m, 1e3 * e.max_m,
              e.points);
  EXPECT_GT(e.points, 100);
  EXPECT_LE(e.rms_m, 0.005);
  const std::string text = readFile(out.string());
  EXPECT_NE(text.find("camera_pose: {height_m: "), std::string::npos) << text;
  EXPECT_NE(text.find("camera_pose_sigma: "), std::string::npos) << text;
  // Again: the first file is kept as .prev.
  ASSERT_EQ(tool(args, dir_).code, 0);
  EXPECT_TRUE(fs::exists(out.string() + ".prev"));
}

TEST_F(CalibrateExtrinsicsTool, RefusesWithTheCauseAndWritesNothing) {
  sim::WorldConfig world = sim::loadWorldConfig(kConfigDir + "world_extrinsics.yaml");
  const fs::path image = render(world, "board.png");
  world.floor_boards.clear();
  const fs::path empty = render(world, "empty.png");
  const std::string info = " --camera-info " + (dir_ / "camera.yaml").string();
  const fs::path out = dir_ / "out.yaml";
  const std::string to = " --out " + out.string();

  ToolRun r = tool("--image " + empty.string() + info + to, dir_);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("board was not found"), std::string::npos);
  r = tool("--image " + image.string() + info + to + " --offset-x 0.6", dir_);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("no Duckiebot can have"), std::string::npos);
  EXPECT_FALSE(fs::exists(out));

  // A camera_info without P: the homography would be for no known rectified image.
  std::string yaml = sim::cameraInfoYaml(camera_);
  yaml = yaml.substr(0, yaml.find("projection_matrix:"));
  writeFileAtomically((dir_ / "no_p.yaml").string(), yaml);
  r = tool("--image " + image.string() + " --camera-info " + (dir_ / "no_p.yaml").string() + to,
           dir_);
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.output.find("projection_matrix"), std::string::npos);
  r = tool("--image " + (dir_ / "missing.png").string() + info + to, dir_);
  EXPECT_EQ(r.code, 2);
  r = tool("--image " + image.string() + info + to + " --board 7", dir_);
  EXPECT_EQ(r.code, 64);
  r = tool("--image " + image.string() + info + to + " --board 6x6", dir_);
  EXPECT_EQ(r.code, 64);
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
