// The camera stage recomputed from a recording (see sweep_replay.h).
#include "autocal/camera/sweep_replay.h"

#include <cmath>

#include "autocal/camera/chessboard.h"
#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace camera {

SweepReplay::SweepReplay(const SweepRunOptions& options, const CameraCalibrationConfig& camera)
    : options_((options.validate(), options)),
      camera_(sweepCameraConfig(camera, options_)),
      collector_(camera_.board, camera_.detector, camera_.selection),
      stillness_(options_.stillness) {}

void SweepReplay::newStop(double stamp_s) {
  stop_s_ = stamp_s;
  taken_ = false;
  first_settled_s_ = -1;
  stillness_.reset();
}

void SweepReplay::addCommand(double stamp_s, const WheelDuties& duties) {
  const bool moving = std::abs(duties.left) > 1e-6 || std::abs(duties.right) > 1e-6;
  if (moving == moving_) return;
  moving_ = moving;
  if (!moving) newStop(stamp_s);  // a stop: its frame is to be taken once settled
}

void SweepReplay::addEncoders(double stamp_s, int left_ticks, int right_ticks,
                              int /*ticks_per_revolution*/, double /*now_s*/) {
  encoders_.add(stamp_s, left_ticks, right_ticks);
}

void SweepReplay::setCollecting(double stamp_s, bool collecting) {
  if (collecting && !collecting_ && !moving_) newStop(std::max(stop_s_, stamp_s));
  collecting_ = collecting;
}

bool SweepReplay::wantsFrame(double stamp_s) const {
  if (!frames_used_.empty()) return collecting_ && frames_used_.count(stamp_s) > 0;
  if (!collecting_ || moving_ || taken_ || !encoders_.valid()) return false;
  return SettleRule{options_.sweep.settle_s, options_.still_s, options_.sweep.max_settle_s}.settled(
      stop_s_, stamp_s, encoders_);
}

bool SweepReplay::addFrame(double stamp_s, const cv::Mat& image, const std::string& source) {
  if (!wantsFrame(stamp_s)) return false;
  if (frames_used_.empty()) {  // SweepRun's rule: the first frame the image shows still
    if (first_settled_s_ < 0) first_settled_s_ = stamp_s;
    if (!stillness_.add(stamp_s, image) &&
        stamp_s < first_settled_s_ + options_.max_still_wait_s)
      return false;
  }
  taken_ = true;
  ++stops_;
  const int frame_index = collector_.frames();
  const size_t sharp_before = collector_.sharpViews().size();
  const FrameResult frame = collector_.addFrame(image, source);
  if (frame.any_kept() || collector_.sharpViews().size() > sharp_before)
    frames_[frame_index] = toGray(image);
  if (!frames_seen_) first_frame_s_ = stamp_s;
  frames_seen_ = true;
  last_frame_s_ = stamp_s;
  return true;
}

std::string SweepReplay::describe() const {
  const Coverage c = collector_.coverage();
  return "replaying: " + std::to_string(stops_) + " stops, " + std::to_string(c.views) +
         " views, " + std::to_string(collector_.sharpViews().size()) + " sharp" +
         (c.sufficient ? ", coverage sufficient" : "");
}

StageStatus SweepReplay::status() const {
  StageStatus s;
  s.step = "replay";
  s.progress = -1;
  s.text = describe();
  s.figures = {{"stops", static_cast<double>(stops_)},
               {"views", static_cast<double>(collector_.coverage().views)}};
  return s;
}

StageResult SweepReplay::finish(const StageOutput& output) {
  const CalibrationResult result = calibrate();  // throws when the gate refuses it
  StageResult r = writeCameraStageFile(output, camera_info_format_, camera_.board, result,
                                       calibrationViews(), frames_);
  r.figures.insert(r.figures.end(),
                   {{"stops", static_cast<double>(stops_)}, {"sweep_s", elapsedS()}});
  r.log += ", " + std::to_string(stops_) + " stops";
  return r;
}

}  // namespace camera
}  // namespace autocal
