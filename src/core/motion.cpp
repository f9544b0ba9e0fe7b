#include "autocal/motion.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {

double RunWatch::tick(double now_s, double max_step_s) {
  if (!started_) {
    started_ = true;
    start_s_ = last_s_ = now_s;
  }
  const double dt = std::clamp(now_s - last_s_, 0.0, max_step_s);
  last_s_ = now_s;
  ++updates_without_encoders_;
  return dt;
}

std::string RunWatch::failure(double now_s, const EncoderTracker& encoders, bool moving,
                              double max_duration_s, double encoder_timeout_s,
                              const std::string& what, const std::string& where) const {
  if (max_duration_s > 0 && now_s - start_s_ > max_duration_s) {
    return "the " + what + " took longer than max_duration_s (" + formatNumber(max_duration_s, 4) +
           " s) in " + where;
  }
  const bool silent = updates_without_encoders_ > kSilentUpdates;
  if (!encoders.valid()) {
    return silent && now_s - start_s_ > encoder_timeout_s ? "no encoder readings" : "";
  }
  if (moving && silent && now_s - encoders.stampS() > encoder_timeout_s)
    return "the encoders went silent for " + formatNumber(now_s - encoders.stampS(), 3) + " s";
  return {};
}

double followRate(double duty, double measured_rate, double target_rate, double gain_per_s,
                  double dt_s, double max_duty) {
  const double error = 1.0 - measured_rate / target_rate;
  return std::clamp(duty + gain_per_s * dt_s * error, 0.0, max_duty);
}

std::string stallOf(int side, const EncoderTracker& encoders, const MotionClock& motion,
                    double now_s, double stall_s, double duty) {
  const double last = std::max(encoders.lastChangeS(side), motion.startS());
  if (now_s - last <= stall_s) return {};
  return std::string("the ") + (side == 0 ? "left" : "right") + " wheel has not moved for " +
         formatNumber(now_s - last, 3) + " s at duty " + formatNumber(duty, 3) +
         " (the robot stalled: blocked, or a motor fault)";
}

void EncoderDriveOptions::validate() const {
  checkConfig(start_duty >= 0 && start_duty < 1, "start_duty", "must be within [0, 1)");
  checkConfig(max_duty > start_duty && max_duty <= 1, "max_duty", "must be within (start_duty, 1]");
  checkConfig(rate_gain_per_s > 0 && rate_gain_per_s < 5, "rate_gain_per_s",
              "must be within (0, 5) [1/s]");
  checkConfig(max_encoder_rate_pulses_per_s > 0, "max_encoder_rate_pulses_per_s", "must be > 0");
  checkConfig(encoder_jump_window_s > 0, "encoder_jump_window_s", "must be > 0 [s]");
  checkConfig(stall_s > 0, "stall_s", "must be > 0 [s]");
  checkConfig(still_s > 0 && settle_s >= 0, "still_s", "still_s must be > 0, settle_s >= 0 [s]");
  checkConfig(encoder_timeout_s > 0, "encoder_timeout_s", "must be > 0 [s]");
}

EncoderDrive::EncoderDrive(const EncoderDriveOptions& options, double max_settle_s)
    : options_(options), max_settle_s_(max_settle_s) {}

std::string EncoderDrive::add(double stamp_s, int left_ticks, int right_ticks,
                              EncoderTracker::Step* step) {
  watch_.noteEncoders();
  *step = encoders_.add(stamp_s, left_ticks, right_ticks);
  if (!step->accepted || step->first) return {};
  return EncoderTracker::jump(*step, options_.max_encoder_rate_pulses_per_s,
                              options_.encoder_jump_window_s);
}

void EncoderDrive::keepSample() {
  const Sample now{encoders_.stampS(), encoders_.left(), encoders_.right()};
  if (!samples_.empty() && samples_.back().stamp_s == now.stamp_s) {
    samples_.back() = now;
  } else {
    samples_.push_back(now);
  }
}

void EncoderDrive::forgetOlderThan(double keep_s) {
  if (samples_.empty()) return;
  const double newest = samples_.back().stamp_s;
  size_t drop = 0;
  while (samples_.size() - drop > 2 && samples_[drop].stamp_s < newest - keep_s) ++drop;
  samples_.erase(samples_.begin(), samples_.begin() + static_cast<std::ptrdiff_t>(drop));
}

double EncoderDrive::rate(int side, double window_s) const {
  if (samples_.size() < 2) return 0.0;
  const Sample& last = samples_.back();
  size_t i = samples_.size() - 1;
  while (i > 0 && samples_[i - 1].stamp_s >= last.stamp_s - window_s) --i;
  const Sample& first = samples_[i];
  const double dt = last.stamp_s - first.stamp_s;
  if (dt < 0.1) return 0.0;
  const double d = side == 0 ? last.left - first.left : last.right - first.right;
  return std::abs(d) / dt;
}

std::string EncoderDrive::tick(double now_s, bool moving, double max_duration_s,
                               const std::string& what, const std::string& where, double* dt_s) {
  *dt_s = watch_.tick(now_s);
  return watch_.failure(now_s, encoders_, moving, max_duration_s, options_.encoder_timeout_s, what,
                        where);
}

void EncoderDrive::startMotion(double now_s, double duty) {
  clock_.reset(now_s);
  duty_[0] = duty_[1] = duty;
}

void EncoderDrive::restartSamples() {
  samples_.clear();
  samples_.push_back({encoders_.stampS(), encoders_.left(), encoders_.right()});
}

void EncoderDrive::follow(int side, double measured_pulses_per_s, double target_pulses_per_s,
                          double dt_s) {
  // Integral control on the wheel's pulse rate: the robot's deadbands and motor gains are unknown
  // to the stage.
  duty_[side] = followRate(duty_[side], measured_pulses_per_s, target_pulses_per_s,
                           options_.rate_gain_per_s, dt_s, options_.max_duty);
}

std::string EncoderDrive::stall(int side, double now_s) const {
  return stallOf(side, encoders_, clock_, now_s, options_.stall_s, duty_[side]);
}

bool EncoderDrive::settled(double now_s) const {
  return SettleRule{options_.settle_s, options_.still_s, max_settle_s_}.settled(stop_s_, now_s,
                                                                                encoders_);
}

}  // namespace autocal
