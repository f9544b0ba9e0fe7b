// The report sheet, a PNG for a person; see sheet.h.
#include "autocal/report/sheet.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/io/format.h"
#include "autocal/report/paths.h"

namespace autocal {
namespace report {

namespace {

const cv::Scalar kBlack(0, 0, 0), kGrey(150, 150, 150), kGreen(40, 150, 40), kRed(40, 40, 210),
    kBlue(200, 90, 30), kWhite(255, 255, 255);

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale = 0.5,
          const cv::Scalar& colour = kBlack, int thickness = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

int textWidth(const std::string& s, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline).width;
}

/// `s` cut (with "...") to at most `max_width_px` at `scale`.
std::string fitted(const std::string& s, double scale, int max_width_px) {
  if (textWidth(s, scale) <= max_width_px) return s;
  std::string cut = s;
  while (!cut.empty() && textWidth(cut + "...", scale) > max_width_px) cut.pop_back();
  return cut + "...";
}

/// A column of text lines in `box` (baselines from its top to its bottom): each line below the
/// last, cut to the box's width; where the lines do not fit, a note says the rest is in the
/// summary.
struct Column {
  static constexpr int kNoteStepPx = 14;
  cv::Rect box;
  int y = 0;  ///< baseline of the last line drawn
  bool full = false;
  /// Draws `s` `step_px` below the last line, `indent_px` in.
  void line(cv::Mat& img, const std::string& s, int step_px, double scale, const cv::Scalar& colour,
            int indent_px = 0, int thickness = 1) {
    if (full) return;
    if (y + step_px + kNoteStepPx > box.y + box.height) {
      text(img, "(the rest in summary.yaml)", {box.x + indent_px, y + kNoteStepPx}, 0.35, kGrey);
      full = true;
      return;
    }
    y += step_px;
    text(img, fitted(s, scale, box.width - indent_px), {box.x + indent_px, y}, scale, colour,
         thickness);
  }
};

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
  text(sheet, "Corner coverage", {area.x, area.y - 8}, 0.55);
  text(sheet, formatNumber(100 * coverage, 3) + " % of the image's 8x6 cells",
       {area.x, area.y + area.height + 18}, 0.45);
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

/// The projection uncertainty's grid as a map over the image: each cell coloured from green
/// (0 px) through yellow to red (1 px and more), its value written in it.
void drawUncertainty(cv::Mat& sheet, cv::Rect area, const ViewsAudit& audit) {
  const bool have = !audit.uncertainty_px.empty() && audit.image_size.width > 0;
  text(sheet, "Projection uncertainty", {area.x, area.y - 8}, 0.55);
  text(sheet,
       have ? "worst " + formatNumber(audit.uncertainty_worst_px, 2) + " px, lower half " +
                  formatNumber(audit.uncertainty_lower_half_worst_px, 2) + " px"
            : std::string("none (no audit, or an equidistant model)"),
       {area.x, area.y + area.height + 18}, 0.45);
  cv::rectangle(sheet, area, kGrey);
  if (!have) return;
  const double s = std::min(double(area.width) / audit.image_size.width,
                            double(area.height) / audit.image_size.height);
  const cv::Rect frame(area.x, area.y, static_cast<int>(audit.image_size.width * s),
                       static_cast<int>(audit.image_size.height * s));
  const int cols = audit.uncertainty_cols, rows = audit.uncertainty_rows;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double v = audit.uncertainty_px[static_cast<size_t>(r * cols + c)];
      const double t = std::min(1.0, std::max(0.0, v));  // 0 .. 1 px
      // BGR: green (0, 200, 0) at 0, yellow (0, 220, 240) at 0.5, red (0, 0, 230) at 1.
      // Grey where the model maps no ray (-1 in views.yaml).
      const cv::Scalar colour =
          std::isfinite(v) && v >= 0
              ? cv::Scalar(0, t < 0.5 ? 200 + 40 * t : 440 * (1 - t), t < 0.5 ? 480 * t : 240)
              : cv::Scalar(160, 160, 160);
      const cv::Rect cell(frame.x + frame.width * c / cols, frame.y + frame.height * r / rows,
                          frame.width * (c + 1) / cols - frame.width * c / cols,
                          frame.height * (r + 1) / rows - frame.height * r / rows);
      cv::rectangle(sheet, cell, colour, cv::FILLED);
    }
  }
  cv::rectangle(sheet, frame, kBlack);
  text(sheet, "1 sigma, worst direction: green 0, yellow 0.5,", {area.x, area.y + area.height + 36},
       0.38, kGrey);
  text(sheet, "red 1 px and more", {area.x, area.y + area.height + 52}, 0.38, kGrey);
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

cv::Mat drawReportSheet(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc,
                        const cv::Mat& ground_view) {
  cv::Mat sheet(1040, 1600, CV_8UC3, kWhite);
  const bool ok = record.succeeded();
  const bool replay = !record.replay_of.empty();
  text(sheet, "autocal self-calibration: " + record.vehicle + (replay ? " (REPLAY)" : ""), {20, 36},
       0.9, kBlack, 2);
  const std::vector<Gate> gates = evaluateGates(record);
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
  drawCoverage(sheet, cv::Rect(1030, 95, 270, 203), audit);
  drawUncertainty(sheet, cv::Rect(1310, 95, 270, 203), audit);
  drawPath(sheet, cv::Rect(20, 680, 620, 330), believedPath(record, options), truePath(record));
  drawIterations(sheet, cv::Rect(670, 680, 500, 330), record.wheel_iterations);

  // The stages' figures (right of the mosaic, between the panels above and the plots' titles
  // below) and the gates (right of the plots).
  Column stages{cv::Rect(1030, 380, 560, 275), 380};
  stages.line(sheet, "Stages", 0, 0.6, kBlack, 0, 2);
  for (const StageRecord& s : record.stages) {
    const cv::Scalar c = s.state == StageState::kDone     ? kGreen
                         : s.state == StageState::kFailed ? kRed
                                                          : kGrey;
    std::string line = s.stage + ": " + s.stateText();
    if (s.end_s >= 0 && s.start_s >= 0) line += ", " + formatNumber(s.end_s - s.start_s, 3) + " s";
    stages.line(sheet, line, 24, 0.5, c);
    // Its first eight figures, as many to a line as fit.
    std::string figs;
    for (size_t i = 0; i < std::min<size_t>(8, s.figures.size()); ++i) {
      const std::string fig =
          s.figures[i].first + " " + formatNumber(s.figures[i].second, 5) + "   ";
      if (!figs.empty() && textWidth(figs + fig, 0.38) > stages.box.width - 15) {
        stages.line(sheet, figs, 18, 0.38, kBlack, 15);
        figs.clear();
      }
      figs += fig;
    }
    if (!figs.empty()) stages.line(sheet, figs, 18, 0.38, kBlack, 15);
  }
  Column gate_column{cv::Rect(1190, 690, 400, 335), 690};
  gate_column.line(sheet, "Gates", 0, 0.6, kBlack, 0, 2);
  for (const Gate& g : gates) {
    gate_column.line(sheet, std::string(g.passed ? "pass  " : "FAIL  ") + g.name, 22, 0.45,
                     g.passed ? kGreen : kRed);
    gate_column.line(sheet, g.detail, 16, 0.35, kGrey, 30);
  }
  return sheet;
}

}  // namespace report
}  // namespace autocal
