// See transport.h.
#include "autocal/sim/transport.h"

#include <algorithm>

namespace autocal {
namespace sim {

double DelayLine::releaseTime(double t_s) {
  if (config_.drop_probability > 0 &&
      std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < config_.drop_probability)
    return -1.0;
  double delay = config_.latency_s;
  if (config_.jitter_s > 0) delay += std::normal_distribution<double>(0.0, config_.jitter_s)(rng_);
  last_release_s_ = std::max(last_release_s_, t_s + std::max(0.0, delay));
  return last_release_s_;
}

}  // namespace sim
}  // namespace autocal
