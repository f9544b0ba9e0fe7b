// rosrun autocal fleet_report_node — ends sim_fleet.launch: waits until every robot's
// run_report_node has written <calibration_root>/report/<veh>/summary.yaml in this run (newer than
// the node's start), prints one line per robot (its result, fx and trim, or why it failed), and
// exits 0 when all succeeded; a robot that failed, or is still running after ~max_wall_s, makes it
// fail naming them (exit 1 through runNode's failure path). doc/nodes/fleet_report_node.md.
//
// Parameters: ~vehicles (comma-separated names, required), ~calibration_root
// (/data/config/calibrations), ~max_wall_s (0: no limit), ~poll_s (0.5, wall).
#include <ros/ros.h>

#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/params.h"

namespace {

namespace fs = std::filesystem;
using autocal::YamlMap;

/// One robot's line from its summary.yaml: "succeeded: fx 317.9, trim 0.0092" or "FAILED: why".
std::string describeRun(const fs::path& root, YamlMap& summary, bool& success) {
  success = summary.required<std::string>("result") == "success";
  if (!success) return "FAILED: " + summary.required<std::string>("failure");
  std::string line = "succeeded";
  YamlMap stages = summary.map("stages");
  try {
    YamlMap camera = YamlMap::loadFile(stages.map("camera").required<std::string>("file"));
    line += ", fx " + autocal::formatNumber(
                          camera.map("camera_matrix").required<std::vector<double>>("data")[0], 5);
    YamlMap wheels = YamlMap::loadFile(stages.map("wheels").required<std::string>("file"));
    line += ", trim " + autocal::formatNumber(wheels.required<double>("trim"), 4);
  } catch (const autocal::Error& e) {
    line += " (" + std::string(e.what()) + ")";
  }
  (void)root;
  return line;
}

void runFleetReport(ros::NodeHandle nh, ros::NodeHandle pnh) {
  const autocal::ros_layer::ParamReader p(pnh, "fleet_report_node");
  std::string vehicles_text, root = "/data/config/calibrations";
  double max_wall_s = 0, poll_s = 0.5;
  p.require("vehicles", vehicles_text);
  p.get("calibration_root", root);
  p.get("max_wall_s", max_wall_s);
  p.get("poll_s", poll_s);
  const std::vector<std::string> vehicles = autocal::splitCommaList(vehicles_text);
  autocal::ros_layer::checkParam(!vehicles.empty(), "vehicles", "must name at least one robot");
  autocal::ros_layer::checkParam(max_wall_s >= 0, "max_wall_s", "must be >= 0 (0: no limit)");
  autocal::ros_layer::checkParam(poll_s > 0, "poll_s", "must be > 0");

  autocal::ros_layer::StatusPublisher status(nh, "fleet/status");
  status.running("fleet/wait", 0, "waiting for " + std::to_string(vehicles.size()) + " robots");
  const auto start = fs::file_time_type::clock::now();
  const ros::WallTime wall_start = ros::WallTime::now();
  std::map<std::string, std::string> ended;  // veh -> its line
  std::vector<std::string> failed;
  ROS_INFO("fleet_report_node: waiting for %zu robots' reports under %s/report/", vehicles.size(),
           root.c_str());
  while (autocal::ros_layer::ok() && ended.size() < vehicles.size()) {
    for (const std::string& v : vehicles) {
      if (ended.count(v)) continue;
      const fs::path summary = fs::path(root) / "report" / v / "summary.yaml";
      std::error_code ec;
      const auto written = fs::last_write_time(summary, ec);
      if (ec || written < start) continue;  // not yet, or an earlier run's
      YamlMap s = YamlMap::loadFile(summary.string());
      bool success = false;
      ended[v] = describeRun(root, s, success);
      if (!success) failed.push_back(v);
      ROS_INFO("fleet_report_node: %s %s (%zu of %zu done, %.0f s)", v.c_str(), ended[v].c_str(),
               ended.size(), vehicles.size(), (ros::WallTime::now() - wall_start).toSec());
      status.running(
          "fleet/wait", static_cast<double>(ended.size()) / vehicles.size(),
          std::to_string(ended.size()) + " of " + std::to_string(vehicles.size()) + " robots done");
    }
    if (max_wall_s > 0 && (ros::WallTime::now() - wall_start).toSec() > max_wall_s) {
      for (const std::string& v : vehicles) {
        if (ended.count(v)) continue;
        ended[v] = "FAILED: still running after max_wall_s";
        failed.push_back(v);
      }
    }
    ros::WallDuration(poll_s).sleep();
  }
  if (!autocal::ros_layer::ok()) return;
  std::ostringstream table;
  for (const std::string& v : vehicles) table << "\n  " << v << ": " << ended[v];
  const double wall = (ros::WallTime::now() - wall_start).toSec();
  ROS_INFO("fleet_report_node: %zu robots in %.0f s of wall time (%.0f s per robot):%s",
           vehicles.size(), wall, wall / vehicles.size(), table.str().c_str());
  if (!failed.empty()) {
    std::string names;
    for (const std::string& v : failed) names += (names.empty() ? "" : ", ") + v;
    throw autocal::CalibrationError(std::to_string(failed.size()) + " of " +
                                    std::to_string(vehicles.size()) + " robots failed: " + names);
  }
  status.done("fleet/report", "all " + std::to_string(vehicles.size()) + " robots succeeded",
              {{"robots", static_cast<double>(vehicles.size())}, {"wall_s", wall}});
}

}  // namespace

int main(int argc, char** argv) {
  autocal::ros_layer::NodeRunOptions options;
  options.name = "fleet_report_node";
  options.phase = "fleet";
  options.status_topic = "fleet/status";
  options.commands_wheels = false;
  return autocal::ros_layer::runNode(argc, argv, options, runFleetReport);
}
