// The camera stage's audit as the report reads it, and the run's gates; see gates.h.
#include "autocal/report/gates.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <tuple>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {
namespace report {

namespace fs = std::filesystem;

ViewsAudit loadViewsAudit(const std::string& views_yaml) {
  if (!fs::exists(views_yaml)) throw IoError(views_yaml + ": no such file");
  YamlMap root = YamlMap::loadFile(views_yaml);
  ViewsAudit audit;
  YamlMap image = root.map("image");
  audit.image_size = {image.required<int>("width"), image.required<int>("height")};
  audit.rms_px = root.optional<double>("rms_px", 0.0);
  if (root.has("projection_uncertainty")) {
    YamlMap u = root.map("projection_uncertainty");
    const std::vector<double> grid = u.required<std::vector<double>>("grid");
    audit.uncertainty_px = u.required<std::vector<double>>("sigma_px");
    if (grid.size() != 2 || grid[0] < 1 || grid[1] < 1 ||
        audit.uncertainty_px.size() != static_cast<size_t>(grid[0] * grid[1]))
      u.fail("sigma_px", "must hold grid[0] x grid[1] values");
    audit.uncertainty_cols = static_cast<int>(grid[0]);
    audit.uncertainty_rows = static_cast<int>(grid[1]);
    audit.uncertainty_worst_px = u.required<double>("worst_px");
    audit.uncertainty_lower_half_worst_px = u.required<double>("lower_half_worst_px");
  }
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

std::vector<Gate> evaluateGates(const RunRecord& record) {
  std::vector<Gate> gates;
  for (const StageRecord& s : record.stages) {
    std::string detail = s.state == StageState::kFailed ? s.failure
                         : s.state == StageState::kDone ? "done"
                                                        : s.stateText();
    if (s.stage == "camera" && s.state == StageState::kDone) {
      // What the stage's gate judged (camera_calibration.yaml quality_gate), as it reported it.
      for (const auto& [name, label, unit] :
           {std::tuple<const char*, const char*, const char*>{"rms_px", "RMS ", " px"},
            {"uncertainty_lower_half_worst_px", "lower-half uncertainty ", " px"},
            {"halves_ratio", "halves ratio ", ""}}) {
        const double v = s.figure(name);
        if (std::isfinite(v)) detail += std::string(", ") + label + formatNumber(v, 3) + unit;
      }
    }
    gates.push_back({s.stage + " stage", s.state == StageState::kDone, detail});
  }
  return gates;
}

}  // namespace report
}  // namespace autocal
