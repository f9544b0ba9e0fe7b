// A calibration stage as every node and harness drives it: the robot's inputs in, wheel duties and
// a status out, and at its end a typed result naming the file it wrote. The runs (camera::SweepRun,
// wheels::WheelRun, odometry::UahRun, odometry::UmbmarkRun) are Stages; ros_layer::StageNode owns
// the ROS side of any of them (doc/calibration_run.md "Nodes"). No ROS.
//
// The caller's loop: inputs as they arrive (addEncoders, addRange, wantsFrame/addFrame), then
// update(now) at the control rate, commanding the duties it returns and publishing status(), until
// done(); then the wheels stop and finish() computes the result and writes its file. Every failure
// is a typed exception (autocal/errors.h), caught once by the node.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "autocal/sensors.h"

namespace autocal {

/// Named figures of a status or a result, in the order they are published.
using Figures = std::vector<std::pair<std::string, double>>;

/// A stage's RUNNING status.
struct StageStatus {
  std::string step;  ///< the phase after "<stage>/", e.g. "collect"
  /// What a watcher acts on (the step, a round, a wait for input): a change is published at
  /// once, the rest at the node's status rate. Empty: the step.
  std::string key;
  double progress = 0.0;  ///< 0..1, negative when unknown
  std::string text;       ///< one line for a person
  Figures figures;
};

/// Where a stage writes its file: <calibration_root>/<kind>/<veh>.yaml.
struct StageOutput {
  std::string calibration_root;
  std::string veh;
};

/// What a finished stage hands on: the DONE status's text, figures and file.
struct StageResult {
  std::string file;  ///< the file written (the next stage and the report read it)
  std::string text;  ///< the DONE text; empty: "wrote <file>"
  Figures figures;
  std::string log;  ///< one line for the node's log (the file's figures)
};

class Stage {
 public:
  virtual ~Stage() = default;

  /// Both encoders' cumulative counts at `stamp_s` (resolution `ticks_per_revolution`), received
  /// at `now_s` on the caller's clock.
  virtual void addEncoders(double stamp_s, int left_ticks, int right_ticks,
                           int ticks_per_revolution, double now_s) = 0;
  /// A range reading; stages that use no range sensor ignore it.
  virtual void addRange(double /*stamp_s*/, double /*range_m*/) {}
  /// Whether the frame stamped `stamp_s` is to be decoded and given to addFrame (a stage takes
  /// only the frames it needs; the rest cost nothing).
  virtual bool wantsFrame(double /*stamp_s*/) const { return false; }
  /// A wanted frame (8-bit grey or colour, one size: the caller drops others); false when it was
  /// not wanted. `source` names it in the stage's records.
  virtual bool addFrame(double /*stamp_s*/, const cv::Mat& /*image*/,
                        const std::string& /*source*/) {
    return false;
  }
  /// Replays of a recording: the command the recorded robot was given at `stamp_s`, and each
  /// status phase of the recorded stage ("camera/collect"). A live stage ignores them.
  virtual void addRecordedCommand(double /*stamp_s*/, const WheelDuties& /*duties*/) {}
  virtual void addRecordedPhase(double /*stamp_s*/, const std::string& /*phase*/) {}
  /// Frames or encoder readings arrived at `now_s` (before their handling took its time).
  virtual void noteFrameArrived(double /*now_s*/) {}
  virtual void noteEncodersArrived(double /*now_s*/) {}

  /// Advances the stage at `now_s`; returns the duties to command now.
  virtual WheelDuties update(double now_s) = 0;
  /// The robot has done its part: the wheels stop and finish() follows.
  virtual bool done() const = 0;
  virtual StageStatus status() const = 0;
  /// The step published while finish() computes ("write", "calibrate").
  virtual std::string finishStep() const { return "write"; }
  /// Computes the result and writes its file (atomically, after its quality gate). Throws on
  /// failure; nothing is written then.
  virtual StageResult finish(const StageOutput& output) = 0;
};

}  // namespace autocal
