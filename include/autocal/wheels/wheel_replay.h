// The wheel stage recomputed from a recording, ROS-free: the passive counterpart of WheelRun. It
// commands nothing; it follows the commands the robot was given (its wheels_cmd) and cuts them
// into motions — drives forward, drives back, turning steps — and the stills between them. In
// each still it takes the frames WheelRun would have measured (after settle_s, once the encoders
// are still), and at the end it does what WheelRun did with them: the heading before and after
// each forward drive that was driven back (paper 000 §3.4) enter the TrimEstimator, the drives'
// encoder rates the MotorFitter. The same options and pieces as the live stage, so a recording
// gives the live result to within what the frames' detection varies.
//
// The intrinsics may come late (the replayed camera stage computes them while the recording
// plays on): frames wanted before setIntrinsics() are kept and detected then.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/wheels/motor_fit.h"
#include "autocal/wheels/tag_heading.h"
#include "autocal/wheels/trim_estimator.h"
#include "autocal/wheels/wheel_run.h"

namespace autocal {
namespace markers {
class TagDetector;
}
namespace wheels {

struct WheelReplayResult {
  /// The calibrated kinematics (WheelRunOptions::kinematics with the replay's trim and offsets).
  KinematicsParams kinematics;
  bool converged = false;
  std::vector<TrimIteration> iterations;
  MotorFit left, right;
  int drives = 0;    ///< forward drives that were driven back (the iteration's drives)
  int stills = 0;    ///< stills in the recording
  int measured = 0;  ///< stills whose frames gave a heading
};

class WheelReplay {
 public:
  /// Throws ConfigError on bad options.
  explicit WheelReplay(const WheelRunOptions& options);
  ~WheelReplay();

  /// The command the robot was given at `stamp_s` (repeats of the same motion are fine).
  void addCommand(double stamp_s, const WheelDuties& duties);
  /// Cumulative ticks of both wheels. Throws InputError on a resolution <= 0.
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution);
  /// A frame is wanted while the robot stands settled in a still whose heading is not measured.
  bool wantsFrame(double stamp_s) const;
  /// A wanted frame (8-bit grey or colour); others are ignored. Throws InputError on a bad image.
  void addFrame(double stamp_s, const cv::Mat& image);
  /// From now on frames are detected (the kept ones at once). Throws ConfigError on bad intrinsics.
  void setIntrinsics(const CameraIntrinsics& intrinsics);
  bool hasIntrinsics() const { return detector_ != nullptr; }

  /// Recomputes the stage from what was added. Throws CalibrationError when the recording holds
  /// no drive over the tags, or when the trim estimation fails as the live stage would have; and
  /// when the intrinsics were never set.
  WheelReplayResult result() const;

  int drives() const;
  int stills() const;
  /// Frames kept for detection (before the intrinsics came).
  int framesKept() const;
  std::string describe() const;

 private:
  enum class Kind { kStill, kForward, kBack, kTurn };
  struct Segment {
    Kind kind = Kind::kStill;
    double start_s = 0;
    int start_left = 0, start_right = 0;
    DriveRecord drive;  // forward and back drives
    // stills: the frames (kept until detected) and what they showed
    std::vector<std::pair<double, cv::Mat>> kept;
    std::vector<std::vector<TagSighting>> frames;
    int with_tags = 0, without_tags = 0;
  };
  static Kind classify(const WheelDuties& d);
  bool stillMeasured(const Segment& s) const;
  void detectInto(Segment& s, const cv::Mat& image);
  HeadingMeasurement stillHeading(const Segment& s) const;

  WheelRunOptions options_;
  std::unique_ptr<markers::TagDetector> detector_;
  std::vector<Segment> segments_;
  EncoderTracker encoders_;
  int ticks_per_rev_ = 0;
};

}  // namespace wheels
}  // namespace autocal
