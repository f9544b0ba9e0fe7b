// What a recording of a stage run in the simulator's core would hold, handed over as it happens:
// the commands the run gave, the encoder readings, the frames (rendered only when someone wants
// them) and the run's phase (what its status would say). The replay tests feed a replay Stage
// from it beside the live run, as `rosrun autocal replay` feeds it a bag.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "autocal/sensors.h"

namespace autocal {
namespace test {

struct RecordingTap {
  virtual ~RecordingTap() = default;
  virtual void command(double /*t_s*/, const WheelDuties& /*duties*/) {}
  virtual void encoders(double /*t_s*/, int /*left*/, int /*right*/, int /*resolution*/) {}
  /// Whether the frame at `t_s` is wanted (then frame() gets it).
  virtual bool wantsFrame(double /*t_s*/) { return false; }
  virtual void frame(double /*t_s*/, const cv::Mat& /*image*/) {}
  /// The run's phase changed, e.g. "camera/collect".
  virtual void phase(double /*t_s*/, const std::string& /*phase*/) {}
};

}  // namespace test
}  // namespace autocal
