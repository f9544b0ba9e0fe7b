// summary.yaml, and writing the report's files; see summary.h.
#include "autocal/report/summary.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/extrinsics/extrinsics_file.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/report/paths.h"
#include "autocal/report/sheet.h"
#include "autocal/wheels/kinematics.h"

namespace autocal {
namespace report {

namespace {

namespace fs = std::filesystem;

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += (c == '\n') ? ' ' : c;
  }
  return out + "\"";
}

std::string num(double v, int digits = 6) {
  return std::isfinite(v) ? formatNumber(v, digits) : std::string(".nan");
}

}  // namespace

std::string summaryYaml(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc) {
  std::ostringstream o;
  o << "# autocal calibration run report: the figures of report.png (README \"Report\")\n";
  o << "vehicle: " << quoted(record.vehicle) << "\n";
  o << "time_utc: " << quoted(time_utc) << "\n";
  if (!record.replay_of.empty()) o << "replay_of: " << quoted(record.replay_of) << "\n";
  // result: every stage DONE (each passed its own gate); gates: each stage's verdict, with the
  // figures the camera stage's gate judged.
  o << "result: " << (record.succeeded() ? "success" : "failed") << "\n";
  o << "failure: " << quoted(record.failure()) << "\n";
  o << "stages:\n";
  for (const StageRecord& s : record.stages) {
    o << "  " << s.stage << ":\n";
    o << "    state: " << s.stateText() << "\n";
    o << "    phase: " << quoted(s.phase) << "\n";
    if (!s.file.empty()) o << "    file: " << quoted(s.file) << "\n";
    if (!s.failure.empty()) o << "    failure: " << quoted(s.failure) << "\n";
    if (!s.text.empty()) o << "    text: " << quoted(s.text) << "\n";
    if (s.start_s >= 0) o << "    duration_s: " << num(s.end_s - s.start_s) << "\n";
    o << "    figures: {";
    for (size_t i = 0; i < s.figures.size(); ++i) {
      o << (i ? ", " : "") << s.figures[i].first << ": " << num(s.figures[i].second, 8);
    }
    o << "}\n";
  }
  o << "camera_views: {count: " << audit.views.size() << ", rms_px: " << num(audit.rms_px)
    << ", corner_coverage: " << num(cornerCoverage(audit), 4) << "}\n";
  o << "wheel_iterations:\n";
  if (record.wheel_iterations.empty()) o << "  []\n";
  for (const WheelIteration& it : record.wheel_iterations) {
    o << "  - {drive: " << it.iteration << ", k: " << num(it.k, 8) << ", trim: " << num(it.trim)
      << ", dtheta_rad: " << num(it.dtheta_rad) << "}\n";
  }
  const std::vector<PathPoint> path = believedPath(record, options);
  const double length = pathLength(path);
  o << "believed_path: {length_m: " << num(length, 4) << ", end: ["
    << (path.empty() ? ".nan" : num(path.back().pose.x_m, 4)) << ", "
    << (path.empty() ? ".nan" : num(path.back().pose.y_m, 4)) << ", "
    << (path.empty() ? ".nan" : num(path.back().pose.yaw_rad, 4)) << "]}\n";
  const std::vector<PathPoint> truth = truePath(record);
  if (!truth.empty()) {
    // How far the believed path strays from the truth: the largest distance between the two at
    // the same instant (the true pose at or just before each believed one).
    double off = 0;
    size_t j = 0;
    for (const PathPoint& p : path) {
      while (j + 1 < truth.size() && truth[j + 1].t_s <= p.t_s) ++j;
      off =
          std::max(off, std::hypot(p.pose.x_m - truth[j].pose.x_m, p.pose.y_m - truth[j].pose.y_m));
    }
    o << "true_path: {length_m: " << num(pathLength(truth), 4)
      << ", believed_off_m: " << num(off, 4) << ", end: [" << num(truth.back().pose.x_m, 4) << ", "
      << num(truth.back().pose.y_m, 4) << ", " << num(truth.back().pose.yaw_rad, 4)
      << "]}  # the simulator's, in the believed path's frame\n";
  }
  const std::vector<Gate> gates = evaluateGates(record);
  o << "gates_passed: "
    << (std::all_of(gates.begin(), gates.end(), [](const Gate& g) { return g.passed; }) ? "true"
                                                                                        : "false")
    << "\n";
  o << "gates:\n";
  for (const Gate& g : gates) {
    o << "  - {name: " << quoted(g.name) << ", passed: " << (g.passed ? "true" : "false")
      << ", detail: " << quoted(g.detail) << "}\n";
  }
  return o.str();
}

PreviousStage previousStage(const std::string& summary_yaml, const std::string& stage) {
  PreviousStage p;
  if (!fs::exists(summary_yaml)) return p;
  YamlMap root = YamlMap::loadFile(summary_yaml);
  if (!root.has("stages")) return p;
  YamlMap stages = root.map("stages");
  if (!stages.has(stage)) return p;
  YamlMap s = stages.map(stage);
  p.done = s.required<std::string>("state") == "done";
  p.file = s.optional<std::string>("file", "");
  // The figures keep their order: yaml-cpp iterates a map in the document's order.
  const YAML::Node figures = YAML::LoadFile(summary_yaml)["stages"][stage]["figures"];
  if (figures && figures.IsMap()) {
    for (const auto& f : figures) {
      try {
        p.figures.emplace_back(f.first.as<std::string>(), f.second.as<double>());
      } catch (const YAML::Exception&) {
        root.fail("stages." + stage + ".figures", "each figure must be a number");
      }
    }
  }
  return p;
}

ReportFiles writeReport(const std::string& dir, const RunRecord& record,
                        const std::string& views_yaml, const ReportOptions& options,
                        const std::string& ground_png) {
  ViewsAudit audit;
  if (!views_yaml.empty() && fs::exists(views_yaml)) audit = loadViewsAudit(views_yaml);
  cv::Mat ground;
  if (!ground_png.empty() && fs::exists(ground_png)) {
    try {
      ground = readImageFile(ground_png, cv::IMREAD_COLOR);
    } catch (const InputError&) {
      // A picture for a person, not a result: the sheet is written without it.
    }
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(dir + ": cannot create: " + ec.message());
  const std::string time_utc = [] {
    const std::time_t t = std::time(nullptr);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
    return std::string(buf);
  }();
  ReportFiles files{(fs::path(dir) / "report.png").string(),
                    (fs::path(dir) / "summary.yaml").string()};
  writePngAtomically(files.sheet_png, drawReportSheet(record, audit, options, time_utc, ground));
  writeFileAtomically(files.summary_yaml, summaryYaml(record, audit, options, time_utc));
  return files;
}

ReportFiles writeRunReport(const std::string& report_dir, const std::string& calibration_root,
                           const std::string& veh, const RunRecord& record, ReportOptions options,
                           std::string* warning) {
  const std::string kin = wheels::kinematicsPath(calibration_root, veh);
  if (fs::exists(kin)) {
    try {
      const wheels::KinematicsParams k = wheels::readKinematicsFile(kin);
      options.wheel_radius_m = k.radius;
      options.baseline_m = k.baseline;
    } catch (const Error& e) {
      if (warning) *warning = kin + ": " + e.what() + "; the path uses the default wheels";
    }
  }
  const std::string views =
      (fs::path(calibration_root) / "camera_intrinsic" / (veh + "_views") / "views.yaml").string();
  const StageRecord* camera = record.stage("camera");
  const bool camera_done = camera && camera->state == StageState::kDone;
  const StageRecord* wheels = record.stage("wheels");
  const bool extrinsics_written =
      wheels && wheels->state == StageState::kDone && wheels->figure("extrinsics_written") == 1.0;
  const std::string ground =
      extrinsics::groundViewPath(extrinsics::extrinsicsPath(calibration_root, veh));
  return writeReport(report_dir, record, camera_done ? views : "", options,
                     extrinsics_written ? ground : "");
}

}  // namespace report
}  // namespace autocal
