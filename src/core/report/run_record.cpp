// The run's record and its recorder, and how a stage looks to a person; see run_record.h.
#include "autocal/report/run_record.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace report {

namespace {

std::string stageOf(const std::string& phase) { return phase.substr(0, phase.find('/')); }

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

}  // namespace report
}  // namespace autocal
