#include "autocal/motion.h"

#include <algorithm>

#include "autocal/io/format.h"

namespace autocal {

double RunWatch::tick(double now_s, double max_step_s) {
  if (!started_) {
    started_ = true;
    start_s_ = last_s_ = now_s;
  }
  const double dt = std::clamp(now_s - last_s_, 0.0, max_step_s);
  last_s_ = now_s;
  return dt;
}

std::string RunWatch::failure(double now_s, const EncoderTracker& encoders, bool moving,
                              double max_duration_s, double encoder_timeout_s,
                              const std::string& what, const std::string& where) const {
  if (max_duration_s > 0 && now_s - start_s_ > max_duration_s) {
    return "the " + what + " took longer than max_duration_s (" + formatNumber(max_duration_s, 4) +
           " s) in " + where;
  }
  if (!encoders.valid()) {
    return now_s - start_s_ > encoder_timeout_s ? "no encoder readings" : "";
  }
  if (moving && now_s - encoders.stampS() > encoder_timeout_s)
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

}  // namespace autocal
