// The core's boundary as a test that fails: no file of the core (include/, src/core/), the sim
// core (sim/include/, sim/src/ outside node/) may include a ROS or message header. Debian puts
// ROS on the default include path, so withholding catkin's include directories from the build
// does not enforce it; this test reads the sources.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// ROS packages and message packages a core file must not include; autocal's own generated
// messages are CamelCase headers under autocal/.
const std::regex kForbidden(
    R"re(^\s*#\s*include\s*[<"]((ros|roscpp|rosbag|rosgraph_msgs|std_msgs|std_srvs|sensor_msgs|geometry_msgs|nav_msgs|tf|tf2|tf2_ros|tf2_msgs|cv_bridge|image_transport|camera_calibration_parsers|camera_info_manager|diagnostic_updater|diagnostic_msgs|nodelet|duckietown_msgs|message_filters|xmlrpcpp|autocal_ros)/|autocal/[A-Z][A-Za-z0-9]*\.h))re");

std::vector<std::string> violations(const std::string& text, const std::string& name) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (std::regex_search(line, kForbidden))
      out.push_back(name + ":" + std::to_string(n) + ": " + line);
  }
  return out;
}

}  // namespace

TEST(CoreBoundary, TheScannerSeesRosIncludes) {
  EXPECT_EQ(violations("#include <ros/ros.h>\n", "a").size(), 1u);
  EXPECT_EQ(violations("#include <sensor_msgs/CameraInfo.h>\n", "a").size(), 1u);
  EXPECT_EQ(violations("  #  include \"autocal/WheelsCmdStamped.h\"\n", "a").size(), 1u);
  EXPECT_EQ(violations("#include \"autocal_ros/params.h\"\n", "a").size(), 1u);
  EXPECT_EQ(violations("#include \"autocal/camera/calibration.h\"\n", "a").size(), 0u);
  EXPECT_EQ(violations("#include <opencv2/core.hpp>\n// ros/ros.h in a comment\n", "a").size(), 0u);
}

TEST(CoreBoundary, NoCoreFileIncludesRos) {
  const fs::path root(AUTOCAL_SOURCE_DIR);
  std::vector<std::string> found;
  int files = 0;
  for (const char* dir : {"include", "src/core", "sim/include", "sim/src"}) {
    for (const auto& e : fs::recursive_directory_iterator(root / dir)) {
      if (!e.is_regular_file()) continue;
      const std::string rel = fs::relative(e.path(), root).string();
      if (rel.rfind("sim/src/node/", 0) == 0) continue;  // the sim's ROS node
      const std::string ext = e.path().extension().string();
      if (ext != ".h" && ext != ".hpp" && ext != ".cpp") continue;
      std::ifstream in(e.path());
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      for (const auto& v : violations(text, rel)) found.push_back(v);
      ++files;
    }
  }
  EXPECT_GT(files, 20) << "the scan found too few files: wrong source dir?";
  for (const auto& v : found) ADD_FAILURE() << v;
}
