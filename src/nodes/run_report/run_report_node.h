// run_report_node — watches a whole calibration run and writes its report (doc/calibration_run.md,
// doc/files.md "The run's report"). It listens to every stage on the one
// status topic and to the encoders; it prints one progress line per stage as the stage goes on;
// when every stage of ~stages is DONE, or one FAILED, it writes report.png and summary.yaml
// (report::RunRecorder, report::writeReport) and exits 0 on success, 1 on failure (the launch files
// make it the node that ends the run).
//
// A stage whose node dies (SIGKILL, a crash: no FAILED of its own) is noticed by pinging the node
// that published the stage's last status; the report node then publishes FAILED for the stage in
// its name (phase "<stage>/died"), so that a later stage waiting for it gives up, and stops the
// wheels (the wheel driver's watchdog stops them too). It never reads a simulator's truth.
//
// Subscribes (relative to the robot's namespace): calibration/status,
// left_wheel_encoder_node/tick, right_wheel_encoder_node/tick. Publishes calibration/status
// (phase run/<step>) and, on failure, wheels_driver_node/wheels_cmd (zero); for a person watching:
// /diagnostics (diagnostic_updater: one status per stage and one for the run) and
// calibration/believed_path (nav_msgs/Path, the encoders' dead reckoning, only while somebody
// subscribes). doc/nodes/run_report_node.md.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <exception>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "autocal/CalibrationStatus.h"
#include "autocal/report/run_report.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace report {

struct RunReportNodeOptions {
  std::string veh;  ///< default: the last component of the node's namespace
  std::string calibration_root = "/data/config/calibrations";
  std::vector<std::string> stages{"camera", "wheels"};  ///< ~stages: "camera,wheels[,odometry]"
  std::string report_dir;                               ///< default <calibration_root>/report/<veh>
  ReportOptions report;
  /// A stage that has not published within this long after the previous one's DONE (the first:
  /// after the report node started) fails [s, node clock; 0: wait for ever].
  double stage_start_timeout_s = 120.0;
  /// How often the node of the running stage is pinged [wall s].
  double ping_period_s = 0.5;
  /// A resumed run (the stages' ~resume): stages this run has no status of keep what the last
  /// report says of them.
  bool resume = false;
  /// The diagnostics WARN when the stage the run waits on has been silent this long [s, node
  /// clock; 0: never].
  double silent_warn_s = 10.0;
  /// calibration/believed_path is republished at most this often [Hz, wall clock].
  double path_rate_hz = 2.0;
  /// nav_msgs/Odometry of the robot's true pose (a simulator's), drawn as the true path; empty:
  /// none.
  std::string true_pose_topic;
  /// The believed path's frame: where the robot started (default "<veh>/odom").
  std::string odom_frame;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

class RunReportNode {
 public:
  RunReportNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Waits for the run to end and writes the report; throws CalibrationError when the run failed
  /// (after writing the report), so that the node exits non-zero.
  void run();

 private:
  void onStatus(const ros::MessageEvent<autocal::CalibrationStatus const>& event);
  void checkStagesAlive();
  void printProgress();
  void stageDiagnostics(const std::string& stage,
                        diagnostic_updater::DiagnosticStatusWrapper& status);
  void runDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  void publishBelievedPath();
  ReportFiles write();

  ros::NodeHandle nh_, pnh_;
  RunReportNodeOptions options_;
  std::unique_ptr<RunRecorder> recorder_;
  ros_layer::StatusPublisher status_;
  ros::Subscriber status_sub_;
  ros::Subscriber sim_status_sub_;  ///< a simulator's own status (sim/status), when one runs
  ros::Subscriber true_pose_sub_;   ///< ~true_pose_topic, when given
  std::unique_ptr<ros_layer::EncoderInput> encoders_;
  std::exception_ptr error_;
  std::map<std::string, std::string> stage_publisher_;  ///< stage → node that published it
  std::map<std::string, std::string> printed_;          ///< stage → last progress line printed
  std::map<std::string, int> failed_pings_;             ///< stage → pings unanswered in a row
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  std::map<std::string, ros::Time> last_heard_;  ///< stage → when its last status came
  std::string diag_current_;                     ///< the stage the run waits on, and since when
  ros::Time diag_current_since_;
  ros::Publisher believed_path_pub_;
  ros::WallTime last_path_;
  ros::WallTime last_ping_;
  ros::Time waiting_since_;
  std::string waiting_for_;
};

}  // namespace report
}  // namespace autocal
