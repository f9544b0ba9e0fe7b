// summary.yaml, the run's figures for a program (and for resuming a run), and writing the report's
// two files atomically beside the calibration files. ROS-free.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "autocal/report/gates.h"
#include "autocal/report/run_record.h"

namespace autocal {
namespace report {

/// summary.yaml's text.
std::string summaryYaml(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc);

/// What a run's summary.yaml says of one stage (for resuming a run after a failure).
struct PreviousStage {
  bool done = false;
  std::string file;
  std::vector<std::pair<std::string, double>> figures;
};
/// Reads `stage` from a summary.yaml that summaryYaml wrote; not done when the file is missing.
/// Throws ConfigError on a malformed file.
PreviousStage previousStage(const std::string& summary_yaml, const std::string& stage);

struct ReportFiles {
  std::string sheet_png, summary_yaml;
};
/// Writes `<dir>/report.png` and `<dir>/summary.yaml`, each atomically (the audit is read from
/// `views_yaml`, the ground view from `ground_png`, each when it exists; a ground view that does
/// not decode is left out). Throws IoError when a file cannot be written.
ReportFiles writeReport(const std::string& dir, const RunRecord& record,
                        const std::string& views_yaml, const ReportOptions& options,
                        const std::string& ground_png = "");

/// The run's report as run_report_node and the replay write it: writeReport into `report_dir`, with
/// the believed path on the wheels the run found (<calibration_root>/kinematics/<veh>.yaml, when it
/// reads; else `options`' and `warning` says why), the camera's audit when the camera stage is
/// DONE, and the ground view when the wheel stage wrote the extrinsics (not an older run's).
ReportFiles writeRunReport(const std::string& report_dir, const std::string& calibration_root,
                           const std::string& veh, const RunRecord& record, ReportOptions options,
                           std::string* warning = nullptr);

}  // namespace report
}  // namespace autocal
