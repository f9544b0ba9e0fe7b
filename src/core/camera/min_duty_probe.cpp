#include "autocal/camera/min_duty_probe.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "autocal/errors.h"

namespace autocal {
namespace camera {

namespace {

WheelCommand stageCommand(int stage) {
  return {stage < 2 ? Wheel::kLeft : Wheel::kRight, stage % 2 == 0 ? 1 : -1};
}

std::string duty2(double d) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", d);
  return buf;
}

}  // namespace

void MinDutyProbeOptions::validate() const {
  checkConfig(std::isfinite(start_duty) && start_duty >= 0 && start_duty <= 1, "start_duty",
              "must be in [0, 1]");
  checkConfig(std::isfinite(duty_step) && duty_step > 0 && duty_step <= 1, "duty_step",
              "must be in (0, 1]");
  checkConfig(std::isfinite(max_duty) && max_duty >= start_duty && max_duty <= 1, "max_duty",
              "must be in [start_duty, 1]");
  checkConfig(min_ticks >= 1, "min_ticks", "must be >= 1");
  checkConfig(std::isfinite(pulse_s) && pulse_s > 0, "pulse_s", "must be > 0");
  checkConfig(std::isfinite(settle_s) && settle_s >= 0, "settle_s", "must be >= 0");
}

double MinDutyResult::forWheel(Wheel wheel, int sign) const {
  if (wheel == Wheel::kLeft) return sign >= 0 ? left_forward : left_backward;
  return sign >= 0 ? right_forward : right_backward;
}

MinDutyProbe::MinDutyProbe(const MinDutyProbeOptions& options)
    : options_(options), duty_(options.start_duty) {
  options_.validate();
}

WheelCommand MinDutyProbe::command() const { return stageCommand(stage_ < 4 ? stage_ : 3); }

void MinDutyProbe::report(int ticks_moved, bool image_moved) {
  if (finished()) return;
  const WheelCommand c = command();
  const std::string wheel = std::string(name(c.wheel)) + " wheel";
  const std::string way = c.sign > 0 ? "forward" : "backward";
  if (-c.sign * ticks_moved >= options_.min_ticks) {
    failure_ = wheel + " turned " + (c.sign > 0 ? "backward" : "forward") + " at " + way +
               " duty " + duty2(duty_) + " (" + std::to_string(ticks_moved) +
               " ticks): motor or encoder wired the other way round";
    return;
  }
  const bool moved =
      c.sign * ticks_moved >= options_.min_ticks || (options_.use_image_motion && image_moved);
  if (moved) {
    double& slot = c.wheel == Wheel::kLeft
                       ? (c.sign > 0 ? result_.left_forward : result_.left_backward)
                       : (c.sign > 0 ? result_.right_forward : result_.right_backward);
    slot = duty_;
    ++stage_;
    duty_ = options_.start_duty;
    return;
  }
  // A small tolerance keeps max_duty itself in the ladder despite rounding of the steps.
  const double next = duty_ + options_.duty_step;
  if (next > options_.max_duty + 1e-9) {
    failure_ =
        wheel + " did not move " + way + " up to duty " + duty2(duty_) + ": encoder or motor fault";
    return;
  }
  duty_ = std::min(next, options_.max_duty);
}

}  // namespace camera
}  // namespace autocal
