// The wheel stage recomputed from a recording, ROS-free: the passive counterpart of WheelRun. It
// commands nothing; it follows the commands the robot was given (its wheels_cmd) and cuts them
// into motions — drives forward, drives back, turning steps — and the stills between them. In
// each still it takes the frames WheelRun would have measured (after settle_s, once the encoders
// are still), and at the end it does what WheelRun did with them: the heading before and after
// each forward drive that was driven back (paper 000 §3.4) enter the TrimEstimator, the drives'
// encoder rates the MotorFitter. The same options and pieces as the live stage, so a recording
// gives the live result to within what the frames' detection varies.
//
// A recording holds its messages in the order they were received, which is not the order they
// were stamped in: on a loaded robot (or a simulator running as fast as it can) a command may be
// written after encoder readings and frames stamped later than it. Everything here goes by the
// messages' stamps: motions are cut at the commands' stamps, ticks read at those stamps, and
// frames put in the still their stamp falls in.
//
// The intrinsics may come late (the replayed camera stage computes them while the recording
// plays on): frames wanted before setIntrinsics() are kept and detected then.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/motion.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"
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

class WheelReplay : public Stage {
 public:
  /// Throws ConfigError on bad options.
  explicit WheelReplay(const WheelRunOptions& options);
  ~WheelReplay();

  /// The command the robot was given at `stamp_s` (repeats of the same motion are fine).
  void addCommand(double stamp_s, const WheelDuties& duties);
  /// Cumulative ticks of both wheels. Throws InputError on a resolution <= 0.
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution,
                   double now_s = 0) override;
  /// A frame is wanted while the robot stands settled in a still whose heading is not measured;
  /// with setFramesUsed, the frames the live stage took.
  bool wantsFrame(double stamp_s) const override;
  /// The stamps of the frames the live stage took (its node records them): the replay measures
  /// each still's heading from the same frames rather than judging by its own rule where a loaded
  /// live node skipped one.
  void setFramesUsed(std::set<double> stamps_s) { frames_used_ = std::move(stamps_s); }
  /// A wanted frame (8-bit grey or colour); others are ignored. Throws InputError on a bad image.
  void addFrame(double stamp_s, const cv::Mat& image);
  bool addFrame(double stamp_s, const cv::Mat& image, const std::string& source) override;
  void addRecordedCommand(double stamp_s, const WheelDuties& duties) override {
    addCommand(stamp_s, duties);
  }
  /// Commands nothing; never done by itself (the recorded stage's end ends it).
  WheelDuties update(double /*now_s*/) override { return {}; }
  bool done() const override { return false; }
  /// Step "replay": drives and stills.
  StageStatus status() const override;
  /// result(), once: the replayed iteration and fit (throws as result(), and CalibrationError when
  /// the iteration did not converge).
  const WheelReplayResult& finalResult();
  /// Writes <calibration_root>/kinematics/<veh>.yaml from finalResult() (validated first).
  StageResult finish(const StageOutput& output) override;
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
  struct Command {
    double stamp_s = 0;
    Kind kind = Kind::kStill;
    WheelDuties duties;
  };
  struct Reading {
    double stamp_s = 0;
    double left = 0, right = 0;  // unwrapped ticks since the first reading
  };
  struct Frame {
    double stamp_s = 0;
    cv::Mat image;  // kept until the intrinsics come
    bool detected = false;
    std::vector<TagSighting> sightings;
  };
  /// A motion between two commands of another kind, cut from the commands by their stamps.
  struct Segment {
    Kind kind = Kind::kStill;
    double start_s = 0, end_s = 0;  // the first still starts at -inf; the last ends at +inf
    DriveRecord drive;
  };
  static Kind classify(const WheelDuties& d);
  /// With `with_samples`, the drives' encoder readings too.
  std::vector<Segment> segments(bool with_samples = false) const;
  /// The segment (of segments()) whose stamps hold `stamp_s`.
  static const Segment& segmentAt(const std::vector<Segment>& segments, double stamp_s);
  /// The unwrapped counts of the latest reading at or before `stamp_s` (the first reading's
  /// before it), as a live stage reading its encoders at that instant has them.
  const Reading& readingAt(double stamp_s) const;
  /// The encoders as of the reading at or before `stamp_s` had not changed for `still_s`, and
  /// that reading is at or after `since_s` (EncoderTracker::stillSince at that instant).
  bool stillAt(double since_s, double stamp_s, double still_s) const;
  /// The stamp of the reading where the counts last changed, as of `stamp_s` (+inf before any).
  double lastChangeAt(double stamp_s) const;
  /// WheelRun would measure a frame at `stamp_s` in `s`: a still, settled.
  bool settledAt(const Segment& s, double stamp_s) const;
  /// No command received is stamped after `stamp_s`: a later one may still come.
  bool undecided(double stamp_s) const;
  /// The frames of a still (by stamp) that WheelRun's rule used, and their count.
  std::vector<const Frame*> framesIn(const Segment& s) const;
  bool measured(const std::vector<const Frame*>& frames) const;
  HeadingMeasurement stillHeading(const Segment& s) const;
  void detect(Frame& f) const;

  WheelRunOptions options_;
  std::set<double> frames_used_;
  std::unique_ptr<markers::TagDetector> detector_;
  std::vector<Command> commands_;  // in stamp order, a motion's repeats left out
  /// Every command of a drive, repeats included, in stamp order: a steered drive back's duties
  /// vary (DriveRecord::commands).
  std::vector<Command> drive_commands_;
  std::vector<Reading> readings_;  // in stamp order
  std::vector<Frame> frames_;      // in stamp order
  EncoderTracker encoders_;
  int ticks_per_rev_ = 0;
  std::unique_ptr<WheelReplayResult> final_;
};

}  // namespace wheels
}  // namespace autocal
