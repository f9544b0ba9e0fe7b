#include "autocal/motion.h"

#include <algorithm>

#include "autocal/io/format.h"

namespace autocal {

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
