#include "autocal/report/run_report.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/odometry/dead_reckoning.h"

namespace autocal {
namespace report {

namespace fs = std::filesystem;

namespace {

std::string stageOf(const std::string& phase) { return phase.substr(0, phase.find('/')); }

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

const cv::Scalar kBlack(0, 0, 0), kGrey(150, 150, 150), kGreen(40, 150, 40), kRed(40, 40, 210),
    kBlue(200, 90, 30), kWhite(255, 255, 255);

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5,
          const cv::Scalar& colour = kBlack, int thickness = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

// A plot frame: maps data (x right, y up) into `box` with equal or free scales.
struct Plot {
  cv::Rect box;
  double x0, x1, y0, y1;
  cv::Point map(double x, double y) const {
    return {box.x + static_cast<int>(std::lround((x - x0) / (x1 - x0) * box.width)),
            box.y + box.height - static_cast<int>(std::lround((y - y0) / (y1 - y0) * box.height))};
  }
};

void drawMosaic(cv::Mat& sheet, cv::Rect area, const ViewsAudit& audit) {
  text(sheet, "Views used by the camera calibration (RMS reprojection error per view)",
       {area.x, area.y - 8}, 0.55);
  cv::rectangle(sheet, area, kGrey);
  if (audit.views.empty()) {
    text(sheet, "no camera views (stage not run or failed)", {area.x + 20, area.y + 40});
    return;
  }
  const int n = static_cast<int>(audit.views.size());
  const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(n * 4.0 / 3.0))));
  const int rows = (n + cols - 1) / cols;
  const int w = area.width / cols, h = std::min(area.height / rows, w * 3 / 4);
  for (int i = 0; i < n; ++i) {
    const AuditView& v = audit.views[i];
    const cv::Rect cell(area.x + (i % cols) * w, area.y + (i / cols) * h, w - 2, h - 2);
    cv::Mat img = cv::imread(v.image, cv::IMREAD_COLOR);
    if (img.empty()) {
      cv::rectangle(sheet, cell, kGrey);
      text(sheet, "missing", {cell.x + 4, cell.y + 14}, 0.35, kRed);
    } else {
      const double s = std::min(double(cell.width) / img.cols, double(cell.height) / img.rows);
      cv::Mat small;
      cv::resize(img, small, cv::Size(), s, s, cv::INTER_AREA);
      for (const cv::Point2f& c : v.corners) {
        cv::circle(small, cv::Point(std::lround(c.x * s), std::lround(c.y * s)), 1, kGreen,
                   cv::FILLED);
      }
      small.copyTo(sheet(cv::Rect(cell.x, cell.y, small.cols, small.rows)));
    }
    text(sheet, formatNumber(v.rms_px, 3) + " px", {cell.x + 3, cell.y + 13}, 0.38, kRed);
  }
}

void drawGroundView(cv::Mat& sheet, cv::Rect area, const cv::Mat& ground) {
  text(sheet, "Floor grid by the camera extrinsics", {area.x, area.y - 8}, 0.55);
  cv::rectangle(sheet, area, kGrey);
  if (ground.empty()) {
    text(sheet, "no ground view (no extrinsics", {area.x + 10, area.y + 40}, 0.45);
    text(sheet, "written by the wheel stage)", {area.x + 10, area.y + 60}, 0.45);
    return;
  }
  const double s =
      std::min(double(area.width - 2) / ground.cols, double(area.height - 2) / ground.rows);
  cv::Mat small;
  cv::resize(ground, small, cv::Size(), s, s, cv::INTER_AREA);
  small.copyTo(sheet(cv::Rect(area.x + 1, area.y + 1, small.cols, small.rows)));
  text(sheet, "lines every 5 cm, 0.1-0.6 m ahead;", {area.x + 4, area.y + small.rows + 22}, 0.4);
  text(sheet, "yellow: the robot's centre line", {area.x + 4, area.y + small.rows + 40}, 0.4);
}

void drawCoverage(cv::Mat& sheet, cv::Rect area, const ViewsAudit& audit) {
  const double coverage = cornerCoverage(audit);
  text(sheet,
       "Image coverage by board corners: " + formatNumber(100 * coverage, 3) + " % of 8x6 cells",
       {area.x, area.y - 8}, 0.55);
  cv::rectangle(sheet, area, kGrey);
  if (!audit.loaded || audit.image_size.width <= 0) return;
  const double s = std::min(double(area.width) / audit.image_size.width,
                            double(area.height) / audit.image_size.height);
  const cv::Rect frame(area.x, area.y, static_cast<int>(audit.image_size.width * s),
                       static_cast<int>(audit.image_size.height * s));
  for (int c = 1; c < 8; ++c) {
    const int x = frame.x + frame.width * c / 8;
    cv::line(sheet, {x, frame.y}, {x, frame.y + frame.height}, cv::Scalar(225, 225, 225));
  }
  for (int r = 1; r < 6; ++r) {
    const int y = frame.y + frame.height * r / 6;
    cv::line(sheet, {frame.x, y}, {frame.x + frame.width, y}, cv::Scalar(225, 225, 225));
  }
  cv::rectangle(sheet, frame, kBlack);
  for (size_t i = 0; i < audit.views.size(); ++i) {
    const cv::Scalar colour((37 * i) % 200, (91 * i + 60) % 200, (53 * i + 120) % 220);
    for (const cv::Point2f& p : audit.views[i].corners) {
      cv::circle(sheet, cv::Point(frame.x + std::lround(p.x * s), frame.y + std::lround(p.y * s)),
                 1, colour, cv::FILLED);
    }
  }
}

double pathLength(const std::vector<PathPoint>& path) {
  double length = 0;
  for (size_t i = 1; i < path.size(); ++i)
    length += std::hypot(path[i].pose.x_m - path[i - 1].pose.x_m,
                         path[i].pose.y_m - path[i - 1].pose.y_m);
  return length;
}

void drawPath(cv::Mat& sheet, cv::Rect area, const std::vector<PathPoint>& path,
              const std::vector<PathPoint>& truth) {
  text(sheet,
       truth.empty() ? "The path the encoders give (believed; start at the circle)"
                     : "The path the encoders give (blue) and the true one (grey; simulator)",
       {area.x, area.y - 8}, 0.55);
  cv::rectangle(sheet, area, kGrey);
  if (path.size() < 2) {
    text(sheet, "no encoder readings", {area.x + 20, area.y + 40});
    return;
  }
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const auto* points : {&path, &truth}) {
    for (const PathPoint& p : *points) {
      x0 = std::min(x0, p.pose.x_m), x1 = std::max(x1, p.pose.x_m);
      y0 = std::min(y0, p.pose.y_m), y1 = std::max(y1, p.pose.y_m);
    }
  }
  // Equal scales, a margin of 10 %, at least 0.5 m across.
  const double span = std::max({x1 - x0, (y1 - y0) * area.width / area.height, 0.5}) * 1.1;
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  const double span_y = span * area.height / area.width;
  const Plot plot{area, cx - span / 2, cx + span / 2, cy - span_y / 2, cy + span_y / 2};
  for (size_t i = 1; i < truth.size(); ++i) {
    cv::line(sheet, plot.map(truth[i - 1].pose.x_m, truth[i - 1].pose.y_m),
             plot.map(truth[i].pose.x_m, truth[i].pose.y_m), kGrey, 3, cv::LINE_AA);
  }
  for (size_t i = 1; i < path.size(); ++i) {
    cv::line(sheet, plot.map(path[i - 1].pose.x_m, path[i - 1].pose.y_m),
             plot.map(path[i].pose.x_m, path[i].pose.y_m), kBlue, 1, cv::LINE_AA);
  }
  cv::circle(sheet, plot.map(path.front().pose.x_m, path.front().pose.y_m), 5, kGreen, 2);
  cv::drawMarker(sheet, plot.map(path.back().pose.x_m, path.back().pose.y_m), kRed,
                 cv::MARKER_CROSS, 10, 2);
  // A scale bar of 0.5 m.
  const cv::Point a(area.x + 10, area.y + area.height - 12);
  const int bar = static_cast<int>(std::lround(0.5 / span * area.width));
  cv::line(sheet, a, {a.x + bar, a.y}, kBlack, 2);
  text(sheet, "0.5 m", {a.x, a.y - 6}, 0.4);
}

void drawIterations(cv::Mat& sheet, cv::Rect area, const std::vector<WheelIteration>& its) {
  text(sheet, "Wheel stage: k (right/left speed ratio) after each drive", {area.x, area.y - 8},
       0.55);
  cv::rectangle(sheet, area, kGrey);
  if (its.empty()) {
    text(sheet, "no drives", {area.x + 20, area.y + 40});
    return;
  }
  double lo = 1e9, hi = -1e9;
  for (const WheelIteration& it : its) lo = std::min(lo, it.k), hi = std::max(hi, it.k);
  lo = std::min(lo, 1.0), hi = std::max(hi, 1.0);
  const double pad = std::max(1e-3, 0.1 * (hi - lo));
  const cv::Rect inner(area.x + 70, area.y + 10, area.width - 90, area.height - 40);
  const Plot plot{inner, 0, double(its.back().iteration + 1), lo - pad, hi + pad};
  for (int t = 0; t <= 4; ++t) {
    const double k = plot.y0 + (plot.y1 - plot.y0) * t / 4;
    const cv::Point p = plot.map(0, k);
    cv::line(sheet, p, {inner.x + inner.width, p.y}, cv::Scalar(225, 225, 225));
    text(sheet, formatNumber(k, 5), {area.x + 4, p.y + 4}, 0.38);
  }
  cv::Point last = plot.map(0, 1.0);
  cv::circle(sheet, last, 3, kGrey, cv::FILLED);
  for (const WheelIteration& it : its) {
    const cv::Point p = plot.map(it.iteration, it.k);
    cv::line(sheet, last, p, kBlue, 1, cv::LINE_AA);
    cv::circle(sheet, p, 3, kBlue, cv::FILLED);
    text(sheet, std::to_string(it.iteration), {p.x - 4, inner.y + inner.height + 16}, 0.38);
    last = p;
  }
  text(sheet, "drive", {inner.x + inner.width - 40, area.y + area.height - 4}, 0.4);
}

}  // namespace

const char* name(StageState state) {
  switch (state) {
    case StageState::kPending:
      return "pending";
    case StageState::kRunning:
      return "running";
    case StageState::kDone:
      return "done";
    case StageState::kFailed:
      return "failed";
  }
  return "?";
}

double StageRecord::figure(const std::string& name) const {
  for (const auto& f : figures)
    if (f.first == name) return f.second;
  return std::numeric_limits<double>::quiet_NaN();
}

bool RunRecord::succeeded() const {
  if (!run_failure.empty()) return false;
  for (const StageRecord& s : stages)
    if (s.state != StageState::kDone) return false;
  return !stages.empty();
}

std::string RunRecord::failure() const {
  for (const StageRecord& s : stages)
    if (s.state == StageState::kFailed) return s.stage + ": " + s.failure;
  if (!run_failure.empty()) return run_failure;
  for (const StageRecord& s : stages)
    if (s.state != StageState::kDone) return s.stage + ": did not end";
  return "";
}

const StageRecord* RunRecord::stage(const std::string& name) const {
  for (const StageRecord& s : stages)
    if (s.stage == name) return &s;
  return nullptr;
}

RunRecorder::RunRecorder(const std::string& vehicle, const std::vector<std::string>& stages) {
  checkConfig(!stages.empty(), "stages", "must name at least one stage");
  std::set<std::string> seen;
  for (const std::string& s : stages) {
    checkConfig(!s.empty() && s.find('/') == std::string::npos && seen.insert(s).second, "stages",
                "must be distinct names without '/' (got \"" + s + "\")");
    StageRecord r;
    r.stage = s;
    record_.stages.push_back(r);
  }
  record_.vehicle = vehicle;
}

StageRecord* RunRecorder::find(const std::string& stage) {
  for (StageRecord& s : record_.stages)
    if (s.stage == stage) return &s;
  return nullptr;
}

void RunRecorder::addStatus(const StatusUpdate& status) {
  StageRecord* s = find(stageOf(status.phase));
  if (!s || s->state == StageState::kDone || s->state == StageState::kFailed) return;
  // A stage's time counts from its first status past waiting for the stage before it.
  const bool waiting =
      status.phase.size() > 5 && status.phase.compare(status.phase.size() - 5, 5, "/wait") == 0;
  if (s->start_s < 0 && !waiting) s->start_s = status.stamp_s;
  s->end_s = status.stamp_s;
  s->phase = status.phase;
  s->text = status.text;
  s->progress = status.progress;
  s->figures = status.figures;
  switch (status.state) {
    case StatusUpdate::State::kDone: {
      s->state = StageState::kDone;
      s->file = status.file;
      break;
    }
    case StatusUpdate::State::kFailed:
      s->state = StageState::kFailed;
      s->failure = status.failure_reason.empty() ? status.text : status.failure_reason;
      break;
    default:
      s->state = StageState::kRunning;
      break;
  }
  if (s->stage == "wheels") {
    // k after each drive: the status figures "iteration" (drives so far), "k", "trim".
    // (the DONE names the count "drives").
    const double it =
        std::isfinite(s->figure("iteration")) ? s->figure("iteration") : s->figure("drives");
    const double k = s->figure("k"), trim = s->figure("trim");
    const int n = std::isfinite(it) ? static_cast<int>(std::lround(it)) : 0;
    auto& its = record_.wheel_iterations;
    if (n > 0 && std::isfinite(k) && (its.empty() || its.back().iteration < n)) {
      its.push_back(
          {n, k, std::isfinite(trim) ? trim : 0.0,
           std::isfinite(s->figure("last_dtheta_rad")) ? s->figure("last_dtheta_rad") : 0.0,
           status.stamp_s});
    } else if (n > 0 && !its.empty() && its.back().iteration == n && std::isfinite(k)) {
      its.back().k = k;  // the DONE's k is the final one
      if (std::isfinite(trim)) its.back().trim = trim;
    }
  }
}

void RunRecorder::addEncoders(double stamp_s, double left, double right, int ticks_per_revolution,
                              double min_interval_s) {
  if (ticks_per_revolution > 0) record_.ticks_per_revolution = ticks_per_revolution;
  auto& e = record_.encoders;
  if (!e.empty() && stamp_s - e.back().stamp_s < min_interval_s) return;
  e.push_back({stamp_s, left, right});
}

void RunRecorder::addEncoderReading(int side, double stamp_s, std::int32_t ticks,
                                    int ticks_per_revolution, double min_interval_s) {
  for (const EncoderPairer::Pair& p : encoder_pairer_.add(side, stamp_s, ticks))
    addEncoders(p.stamp_s, p.left_ticks, p.right_ticks, ticks_per_revolution, min_interval_s);
}

void RunRecorder::addTruePose(double stamp_s, const Pose2D& pose, double min_interval_s) {
  auto& poses = record_.true_poses;
  if (!poses.empty() && stamp_s - poses.back().first < min_interval_s) return;
  poses.emplace_back(stamp_s, pose);
}

void RunRecorder::markStageDead(const std::string& stage, const std::string& why) {
  StageRecord* s = find(stage);
  if (!s || s->state == StageState::kDone || s->state == StageState::kFailed) return;
  s->state = StageState::kFailed;
  s->failure = why;
}

void RunRecorder::keepFromLastRun(const std::string& stage, const std::string& file,
                                  const std::vector<std::pair<std::string, double>>& figures) {
  StageRecord* s = find(stage);
  if (!s || s->state != StageState::kPending) return;
  s->state = StageState::kDone;
  s->phase = stage + "/resumed";
  s->text = "kept " + file;
  s->file = file;
  s->figures = figures;
}

void RunRecorder::markInterrupted(const std::string& why) {
  if (!ended()) record_.run_failure = why;
}

bool RunRecorder::ended() const {
  if (!record_.run_failure.empty()) return true;
  bool all_done = true;
  for (const StageRecord& s : record_.stages) {
    if (s.state == StageState::kFailed) return true;
    all_done = all_done && s.state == StageState::kDone;
  }
  return all_done;
}

std::string RunRecorder::currentStage() const {
  if (ended()) return "";
  for (const StageRecord& s : record_.stages)
    if (s.state != StageState::kDone) return s.stage;
  return "";
}

std::string StageRecord::stateText() const {
  if ((state == StageState::kPending || state == StageState::kRunning) && !started())
    return "not started";
  return name(state);
}

StageHealth stageHealth(const StageRecord& stage, bool current, double silent_s,
                        double warn_after_s) {
  StageHealth h;
  switch (stage.state) {
    case StageState::kFailed:
      h.level = StageHealth::Level::kError;
      h.message = "failed: " + stage.failure;
      return h;
    case StageState::kDone:
      h.message = "done" + (stage.text.empty() ? std::string() : ": " + stage.text);
      return h;
    case StageState::kPending:
      h.message = current ? "waiting for the stage to start" : "pending";
      break;
    case StageState::kRunning:
      h.message = stage.phase;
      if (stage.progress >= 0)
        h.message += " " + std::to_string(static_cast<int>(100 * stage.progress)) + " %";
      if (!stage.text.empty()) h.message += ": " + stage.text;
      break;
  }
  if (current && warn_after_s > 0 && silent_s > warn_after_s) {
    h.level = StageHealth::Level::kWarn;
    h.message = "silent for " + formatNumber(silent_s, 3) + " s (" + h.message + ")";
  }
  return h;
}

namespace {

std::vector<PathPoint> deadReckoned(const RunRecord& record,
                                    const odometry::DiffDriveParams& wheels) {
  std::vector<PathPoint> path;
  if (record.encoders.empty()) return path;
  odometry::DeadReckoning odometry(wheels, odometry::Integrator::kRungeKutta2);
  path.push_back({record.encoders.front().stamp_s, odometry.pose()});
  for (size_t i = 1; i < record.encoders.size(); ++i) {
    const EncoderSample &a = record.encoders[i - 1], &b = record.encoders[i];
    odometry.addPulses(b.left - a.left, b.right - a.right);
    path.push_back({b.stamp_s, odometry.pose()});
  }
  return path;
}

}  // namespace

std::vector<PathPoint> believedPath(const RunRecord& record, double wheel_radius_m,
                                    double baseline_m) {
  if (record.ticks_per_revolution <= 0) return {};
  return deadReckoned(record, odometry::DiffDriveParams::fromWheel(
                                  2 * wheel_radius_m, record.ticks_per_revolution, baseline_m));
}

std::vector<PathPoint> believedPath(const RunRecord& record, const ReportOptions& options) {
  const StageRecord* odometry = record.stage("odometry");
  if (odometry && odometry->state == StageState::kDone) {
    const odometry::DiffDriveParams wheels{odometry->figure("left_m_per_pulse"),
                                           odometry->figure("right_m_per_pulse"),
                                           odometry->figure("wheelbase_m")};
    if (wheels.left_m_per_pulse > 0 && wheels.right_m_per_pulse > 0 && wheels.wheelbase_m > 0)
      return deadReckoned(record, wheels);  // NaN figures fail the comparisons
  }
  return believedPath(record, options.wheel_radius_m, options.baseline_m);
}

std::vector<PathPoint> truePath(const RunRecord& record) {
  std::vector<PathPoint> path;
  if (record.true_poses.empty() || record.encoders.empty()) return path;
  // The true pose when the believed path starts: the last one at or before its first reading.
  const double start_s = record.encoders.front().stamp_s;
  Pose2D origin = record.true_poses.front().second;
  for (const auto& [t, pose] : record.true_poses) {
    if (t > start_s) break;
    origin = pose;
  }
  const double c = std::cos(origin.yaw_rad), s = std::sin(origin.yaw_rad);
  path.push_back({start_s, Pose2D()});
  for (const auto& [t, pose] : record.true_poses) {
    if (t <= start_s) continue;
    const double dx = pose.x_m - origin.x_m, dy = pose.y_m - origin.y_m;
    path.push_back({t,
                    {c * dx + s * dy, -s * dx + c * dy,
                     std::remainder(pose.yaw_rad - origin.yaw_rad, 2 * M_PI)}});
  }
  return path;
}

ViewsAudit loadViewsAudit(const std::string& views_yaml) {
  if (!fs::exists(views_yaml)) throw IoError(views_yaml + ": no such file");
  YamlMap root = YamlMap::loadFile(views_yaml);
  ViewsAudit audit;
  YamlMap image = root.map("image");
  audit.image_size = {image.required<int>("width"), image.required<int>("height")};
  audit.rms_px = root.optional<double>("rms_px", 0.0);
  const fs::path dir = fs::path(views_yaml).parent_path();
  for (YamlMap& v : root.optionalMapList("views")) {
    AuditView view;
    view.image = (dir / v.required<std::string>("image")).string();
    view.rms_px = v.optional<double>("rms_px", 0.0);
    for (const std::vector<double>& c : v.required<std::vector<std::vector<double>>>("corners")) {
      if (c.size() != 2) v.fail("corners", "each corner must be [x, y]");
      view.corners.emplace_back(static_cast<float>(c[0]), static_cast<float>(c[1]));
    }
    audit.views.push_back(std::move(view));
  }
  audit.loaded = true;
  return audit;
}

double cornerCoverage(const ViewsAudit& audit, int cols, int rows) {
  if (!audit.loaded || audit.image_size.width <= 0 || audit.image_size.height <= 0) return 0.0;
  std::set<int> cells;
  for (const AuditView& v : audit.views) {
    for (const cv::Point2f& p : v.corners) {
      const int c = static_cast<int>(p.x * cols / audit.image_size.width);
      const int r = static_cast<int>(p.y * rows / audit.image_size.height);
      if (c >= 0 && c < cols && r >= 0 && r < rows) cells.insert(r * cols + c);
    }
  }
  return static_cast<double>(cells.size()) / (cols * rows);
}

std::vector<Gate> evaluateGates(const RunRecord& record, const ViewsAudit& audit,
                                const ReportOptions& options) {
  std::vector<Gate> gates;
  for (const StageRecord& s : record.stages) {
    gates.push_back({s.stage + " stage", s.state == StageState::kDone,
                     s.state == StageState::kFailed ? s.failure
                     : s.state == StageState::kDone ? "done"
                                                    : s.stateText()});
  }
  if (const StageRecord* camera = record.stage("camera")) {
    if (camera->state == StageState::kDone) {
      const double rms = camera->figure("rms_px");
      gates.push_back({"camera RMS reprojection error", rms <= options.max_camera_rms_px,
                       formatNumber(rms, 3) + " px (at most " +
                           formatNumber(options.max_camera_rms_px, 3) + ")"});
      const double coverage = cornerCoverage(audit);
      gates.push_back({"camera corner coverage", coverage >= options.min_corner_coverage,
                       formatNumber(100 * coverage, 3) + " % of the image (at least " +
                           formatNumber(100 * options.min_corner_coverage, 3) + " %)"});
    }
  }
  return gates;
}

cv::Mat drawReportSheet(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc,
                        const cv::Mat& ground_view) {
  cv::Mat sheet(1040, 1600, CV_8UC3, kWhite);
  const bool ok = record.succeeded();
  const bool replay = !record.replay_of.empty();
  text(sheet, "autocal self-calibration: " + record.vehicle + (replay ? " (REPLAY)" : ""),
       {20, 36}, 0.9, kBlack, 2);
  const std::vector<Gate> gates = evaluateGates(record, audit, options);
  const auto passed =
      std::count_if(gates.begin(), gates.end(), [](const Gate& g) { return g.passed; });
  text(sheet, ok ? "SUCCESS" : "FAILED", {620, 36}, 0.9, ok ? kGreen : kRed, 2);
  text(sheet, std::to_string(passed) + " of " + std::to_string(gates.size()) + " gates passed",
       {800, 36}, 0.7, passed == static_cast<long>(gates.size()) ? kGreen : kRed, 2);
  text(sheet, time_utc, {1340, 36}, 0.5, kGrey);
  std::string second_line = ok ? "" : record.failure();
  if (replay) {
    second_line += std::string(second_line.empty() ? "" : "; ") + "a replay of the recording " +
                   record.replay_of + " (no robot drove)";
  }
  if (!second_line.empty()) text(sheet, second_line, {20, 62}, 0.5, ok ? kBlack : kRed);

  drawMosaic(sheet, cv::Rect(20, 95, 660, 540), audit);
  drawGroundView(sheet, cv::Rect(700, 95, 310, 300), ground_view);
  drawCoverage(sheet, cv::Rect(1030, 95, 550, 413), audit);
  drawPath(sheet, cv::Rect(20, 680, 620, 330), believedPath(record, options), truePath(record));
  drawIterations(sheet, cv::Rect(670, 680, 500, 330), record.wheel_iterations);

  // The stages' figures and the gates.
  int y = 560;
  text(sheet, "Stages", {1030, y}, 0.6, kBlack, 2);
  for (const StageRecord& s : record.stages) {
    y += 24;
    const cv::Scalar c = s.state == StageState::kDone     ? kGreen
                         : s.state == StageState::kFailed ? kRed
                                                          : kGrey;
    std::string line = s.stage + ": " + s.stateText();
    if (s.end_s >= 0 && s.start_s >= 0) line += ", " + formatNumber(s.end_s - s.start_s, 3) + " s";
    text(sheet, line, {1030, y}, 0.5, c);
    // Its first eight figures, four to a line.
    for (size_t i = 0; i < std::min<size_t>(8, s.figures.size()); i += 4) {
      std::string figs;
      for (size_t j = i; j < std::min(i + 4, s.figures.size()); ++j)
        figs += s.figures[j].first + " " + formatNumber(s.figures[j].second, 5) + "   ";
      y += 18;
      text(sheet, figs, {1045, y}, 0.38);
    }
  }
  y = std::max(y, 700) + 10;
  text(sheet, "Gates", {1200, y}, 0.6, kBlack, 2);
  for (const Gate& g : gates) {
    y += 22;
    if (y > 1020) break;
    text(sheet, std::string(g.passed ? "pass  " : "FAIL  ") + g.name, {1200, y}, 0.45,
         g.passed ? kGreen : kRed);
    y += 16;
    text(sheet, g.detail.substr(0, 60), {1230, y}, 0.35, kGrey);
  }
  return sheet;
}

std::string summaryYaml(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc) {
  std::ostringstream o;
  o << "# autocal calibration run report: the figures of report.png (README \"Report\")\n";
  o << "vehicle: " << quoted(record.vehicle) << "\n";
  o << "time_utc: " << quoted(time_utc) << "\n";
  if (!record.replay_of.empty()) o << "replay_of: " << quoted(record.replay_of) << "\n";
  // result: every stage DONE (each passed its own gates); gates_passed adds the report's.
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
  const std::vector<Gate> gates = evaluateGates(record, audit, options);
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

}  // namespace report
}  // namespace autocal
