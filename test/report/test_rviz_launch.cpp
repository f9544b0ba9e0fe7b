// calibrate_sim.launch rviz:=true (README "RViz"), without starting anything (tests run headless;
// RViz need not be installed): the launch parses with and without RViz, adds RViz and the camera
// view exactly when asked, and the shipped RViz config shows the topics the nodes publish.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdio>
#include <set>
#include <string>

namespace {

const std::string kSource = AUTOCAL_SOURCE_DIR;

/// Runs `roslaunch ARGS` (this source tree first on ROS_PACKAGE_PATH); its output and exit status.
int roslaunch(const std::string& args, std::string* out) {
  const std::string cmd = "ROS_PACKAGE_PATH=" + kSource +
                          ":${ROS_PACKAGE_PATH:-/usr/share} PATH=/usr/bin:/bin:$PATH roslaunch " +
                          args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return -1;
  std::array<char, 512> buf;
  out->clear();
  while (fgets(buf.data(), buf.size(), pipe)) *out += buf.data();
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(RvizLaunch, StartsRvizAndTheCameraViewOnlyWhenAsked) {
  std::string out;
  ASSERT_EQ(roslaunch("--nodes autocal calibrate_sim.launch rviz:=true veh:=vizbot", &out), 0)
      << out;
  EXPECT_NE(out.find("/vizbot/rviz\n"), std::string::npos) << out;
  EXPECT_NE(out.find("/vizbot/camera_view_node\n"), std::string::npos) << out;
  EXPECT_NE(out.find("/vizbot/run_report_node\n"), std::string::npos) << out;
  EXPECT_NE(out.find("/vizbot/sim_node\n"), std::string::npos) << out;

  ASSERT_EQ(roslaunch("--nodes autocal calibrate_sim.launch veh:=vizbot", &out), 0) << out;
  EXPECT_EQ(out.find("rviz"), std::string::npos) << "rviz:=false is the default: " << out;
  EXPECT_EQ(out.find("camera_view_node"), std::string::npos) << out;
  EXPECT_NE(out.find("/vizbot/run_report_node\n"), std::string::npos) << out;

  // The camera view is one of ours: its executable is built and found.
  ASSERT_EQ(roslaunch("--args /vizbot/camera_view_node autocal calibrate_sim.launch rviz:=true "
                      "veh:=vizbot",
                      &out),
            0)
      << out;
  EXPECT_NE(out.find("camera_view_node"), std::string::npos) << out;
  EXPECT_NE(roslaunch("--nodes autocal calibrate_sim.launch rviz:=perhaps", &out), 0)
      << "a bad value must not pass: " << out;
}

TEST(RvizLaunch, TheConfigShowsWhatTheNodesPublish) {
  const YAML::Node config = YAML::LoadFile(kSource + "/config/autocal.rviz");
  const YAML::Node manager = config["Visualization Manager"];
  ASSERT_TRUE(manager.IsMap());
  EXPECT_EQ(manager["Global Options"]["Fixed Frame"].as<std::string>(), "world");
  std::set<std::string> shown;  // "class topic" of every enabled display
  for (const YAML::Node& d : manager["Displays"]) {
    if (!d["Enabled"].as<bool>()) continue;
    const std::string cls = d["Class"].as<std::string>();
    for (const char* key : {"Topic", "Marker Topic", "Image Topic"})
      if (d[key]) shown.insert(cls + " " + d[key].as<std::string>());
  }
  // Relative topics: RViz runs in the robot's namespace (launch/rviz.launch).
  for (const char* expected :
       {"rviz/MarkerArray sim/world_markers", "rviz/Path sim/true_path",
        "rviz/Path calibration/believed_path", "rviz/Image camera_view/image"}) {
    EXPECT_EQ(shown.count(expected), 1u) << expected;
  }
}

}  // namespace
