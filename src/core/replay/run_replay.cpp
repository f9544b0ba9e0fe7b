#include "autocal/replay/run_replay.h"

#include <algorithm>
#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/camera_info_file.h"
#include "autocal/wheels/kinematics.h"

namespace autocal {
namespace replay {

namespace {
using State = report::StatusUpdate::State;
}  // namespace

RunReplay::RunReplay(RunReplayOptions options)
    : options_(std::move(options)), recorder_(options_.veh, options_.stages) {
  recorder_.setReplayOf(options_.recording);
  for (const std::string& s : options_.stages)
    if (s != "camera" && s != "wheels" && s != "odometry")
      throw ConfigError("stage '" + s +
                        "': a replay recomputes the camera, wheel and odometry stages");
  // Given intrinsics that cannot be read fail before the recording is read.
  if (!options_.intrinsics_file.empty()) loadCameraInfoYaml(options_.intrinsics_file);
}

RunReplay::~RunReplay() = default;

const std::string& RunReplay::current() const {
  static const std::string none;
  return current_ < options_.stages.size() ? options_.stages[current_] : none;
}

std::string RunReplay::noun(const std::string& stage) {
  return stage == "wheels" ? "wheel" : stage;
}

void RunReplay::log(const std::string& line) const {
  if (options_.log) options_.log(line);
}

void RunReplay::status(double stamp_s, State state, const std::string& step,
                       const std::string& text, const Figures& figures, const std::string& file) {
  report::StatusUpdate s;
  s.stamp_s = stamp_s;
  s.phase = current() + "/" + step;
  s.state = state;
  s.text = text;
  if (state == State::kFailed) s.failure_reason = text;
  s.file = file;
  s.figures = figures;
  if (state == State::kDone) s.progress = 1;
  recorder_.addStatus(s);
}

void RunReplay::addCameraInfo(const CameraIntrinsics& nominal) {
  if (have_nominal_ || !(nominal.fx > 0) || nominal.width <= 0) return;
  nominal_ = nominal;
  have_nominal_ = true;
  if (frame_size_.area() == 0) frame_size_ = nominal.imageSize();
  if (!stage_ && current() == "camera" && !recorder_.ended()) build(last_stamp_s_);
}

void RunReplay::addEncoderReading(int side, double stamp_s, std::int32_t ticks,
                                  int ticks_per_revolution) {
  last_stamp_s_ = std::max(last_stamp_s_, stamp_s);
  recorder_.addEncoderReading(side, stamp_s, ticks, ticks_per_revolution);
  ticks_[side] = ticks;
  have_ticks_[side] = true;
  const auto pairs = pairer_.add(side, stamp_s, ticks);
  if (!stage_) return;
  if (wheel_) {
    for (const EncoderPairer::Pair& p : pairs)
      stage_->addEncoders(p.stamp_s, static_cast<int>(std::lround(p.left_ticks)),
                          static_cast<int>(std::lround(p.right_ticks)), ticks_per_revolution,
                          p.stamp_s);
  } else if (have_ticks_[0] && have_ticks_[1]) {
    stage_->addEncoders(stamp_s, ticks_[0], ticks_[1], ticks_per_revolution, stamp_s);
  }
}

bool RunReplay::wantsFrame(double stamp_s) const { return stage_ && stage_->wantsFrame(stamp_s); }

void RunReplay::addFrame(double stamp_s, const cv::Mat& gray, const std::string& source) {
  last_stamp_s_ = std::max(last_stamp_s_, stamp_s);
  if (!stage_) return;
  // The camera's size (camera_info's, else the first frame's): another is dropped.
  if (frame_size_.area() > 0 && gray.size() != frame_size_) {
    ++frames_dropped_;
    return;
  }
  if (frame_size_.area() == 0) frame_size_ = gray.size();
  stage_->addFrame(stamp_s, gray, source);
}

void RunReplay::addCommand(double stamp_s, const WheelDuties& duties) {
  last_stamp_s_ = std::max(last_stamp_s_, stamp_s);
  if (stage_) stage_->addRecordedCommand(stamp_s, duties);
}

void RunReplay::addRecordedStatus(const report::StatusUpdate& recorded) {
  last_stamp_s_ = std::max(last_stamp_s_, recorded.stamp_s);
  if (recorder_.ended()) return;
  const std::string& stage = current();
  if (recorded.phase.rfind(stage + "/", 0) != 0) return;
  const bool ended = recorded.state == State::kDone || recorded.state == State::kFailed;
  if (stage == "odometry") {
    // Recomputed from the whole recording at the recorded stage's end.
    if (!odometry_started_ && recorded.phase != stage + "/wait" && !ended) {
      odometry_started_ = true;
      log("odometry: the recorded stage began: replaying it at its end");
      status(recorded.stamp_s, State::kRunning, "replay", "replaying the recorded stage", {});
    }
    if (ended) finishOdometry(recorded.stamp_s);
    return;
  }
  if (!stage_ && recorded.phase != stage + "/wait") build(recorded.stamp_s);
  if (stage_) {
    stage_->addRecordedPhase(recorded.stamp_s, recorded.phase);
    const StageStatus s = stage_->status();
    status(recorded.stamp_s, State::kRunning, s.step, s.text, s.figures);
  }
  if (!ended) return;
  if (recorded.state == State::kFailed)
    log("the recorded " + noun(stage) + " stage FAILED (" + recorded.failure_reason +
        "); recomputing what it did");
  if (!stage_) {
    fail(recorded.stamp_s,
         "the recorded " + noun(stage) + " stage ended before it began: nothing to replay (" +
             (recorded.failure_reason.empty() ? recorded.text : recorded.failure_reason) + ")");
    return;
  }
  finishStage(recorded.stamp_s);
}

void RunReplay::build(double stamp_s) {
  const std::string& stage = current();
  if (stage == "camera") {
    camera::CameraCalibrationConfig camera = options_.camera;
    camera::SweepRunOptions run = options_.camera_run;
    if (have_nominal_) {
      camera::useNominalCamera(nominal_, options_.use_camera_info_guess, camera, run);
    } else {
      log("camera: no camera_info in the recording before the stage began: the sweep's field of "
          "view is " +
          std::to_string(run.sweep.camera_hfov_rad) + " rad");
    }
    auto sweep = std::make_unique<camera::SweepReplay>(run, camera);
    sweep->setCameraInfoFormat(options_.camera_info_format);
    if (frames_used_.count(stage)) sweep->setFramesUsed(frames_used_.at(stage));
    stage_ = std::move(sweep);
  } else {
    wheels::WheelRunOptions run = options_.wheel_run;
    auto wheel = std::make_unique<wheels::WheelReplay>(run);
    if (frames_used_.count(stage)) wheel->setFramesUsed(frames_used_.at(stage));
    if (!options_.intrinsics_file.empty()) {
      const CameraIntrinsics intrinsics = loadCameraInfoYaml(options_.intrinsics_file);
      wheel->setIntrinsics(intrinsics);
      frame_size_ = intrinsics.imageSize();
      log("wheels: intrinsics " + options_.intrinsics_file);
    }
    wheel_ = wheel.get();
    stage_ = std::move(wheel);
  }
  log(stage + ": the recorded stage began: replaying it" +
      (frames_used_.count(stage)
           ? " on the " + std::to_string(frames_used_.at(stage).size()) + " frames it took"
           : std::string(" (the recording names no frame it took: the replay's own choice)")));
  const StageStatus s = stage_->status();
  status(stamp_s, State::kRunning, s.step, s.text, s.figures);
}

void RunReplay::finishStage(double stamp_s) {
  try {
    if (wheel_) {
      if (!wheel_->hasIntrinsics())
        throw CalibrationError(
            "the wheel stage has no intrinsics: the camera stage gave none, "
            "and no intrinsics file was given");
      // Each update of the replayed iteration, as the live stage published them (the report's k
      // plot).
      const wheels::WheelReplayResult& result = wheel_->finalResult();
      for (std::size_t i = 0; i < result.iterations.size(); ++i) {
        const wheels::TrimIteration& it = result.iterations[i];
        status(stamp_s, State::kRunning, "replay", wheel_->describe(),
               {{"iteration", static_cast<double>(i + 1)},
                {"k", it.ratio_after},
                {"trim", wheels::trimFromSpeedRatio(it.ratio_after, result.kinematics.gain)},
                {"last_dtheta_rad", it.delta_theta_rad}});
      }
    }
    status(stamp_s, State::kRunning, stage_->finishStep(), stage_->status().text, {});
    StageResult result = stage_->finish({options_.calibration_root, options_.veh});
    result.figures.emplace_back("frames_dropped", static_cast<double>(frames_dropped_));
    done(stamp_s, std::move(result));
  } catch (const Error& e) {
    fail(stamp_s, e.what());
  }
}

void RunReplay::finishOdometry(double stamp_s) {
  if (!odometry_started_) {
    fail(stamp_s, "the recorded odometry stage ended before it began: nothing to replay");
    return;
  }
  try {
    if (!options_.odometry) throw ConfigError("the replay was given no odometry recomputation");
    done(stamp_s, options_.odometry({options_.calibration_root, options_.veh}));
  } catch (const Error& e) {
    fail(stamp_s, e.what());
  }
}

void RunReplay::done(double stamp_s, StageResult result) {
  const std::string stage = current();
  const std::string text = result.text.empty() ? "wrote " + result.file : result.text;
  status(stamp_s, State::kDone, "write", text, result.figures, result.file);
  log(stage + ": DONE: " + text + (result.log.empty() ? "" : " (" + result.log + ")"));
  if (stage == "camera" && options_.intrinsics_file.empty()) options_.intrinsics_file = result.file;
  stage_.reset();
  wheel_ = nullptr;
  frames_dropped_ = 0;
  ++current_;
}

void RunReplay::fail(double stamp_s, const std::string& why) {
  const std::string step = stage_ ? stage_->status().step : "wait";
  status(stamp_s, State::kFailed, step, why, {});
  log(current() + ": FAILED: " + why);
}

void RunReplay::endOfRecording() {
  if (recorder_.ended()) return;
  const std::string stage = noun(current());
  fail(last_stamp_s_, "the recording ended before its " + stage + " stage did (" + describe() +
                          (stage_ ? "; the stage's end is not in it)"
                                  : "; no status of the " + stage +
                                        " stage in it: was calibration/status recorded?)"));
}

std::string RunReplay::describe() const {
  if (recorder_.ended()) return "the replay ended";
  if (current() == "odometry" && odometry_started_) return "odometry: following the recorded stage";
  if (!stage_) return "waiting for the recorded " + noun(current()) + " stage";
  return current() + ": " + stage_->status().text;
}

}  // namespace replay
}  // namespace autocal
