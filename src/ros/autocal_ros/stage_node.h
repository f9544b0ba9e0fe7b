// The ROS side of any calibration Stage (autocal/stage.h), one implementation for every node: the
// private parameters all stages share, the wait for the stage before, the robot's inputs
// (encoders, frames, ranges), the wheels, the throttled status, the one failure path (exceptions
// reach runNode) and the DONE that hands on the file written. A node adds only what its stage
// alone has: its options, how its stage is built, and its extra topics.
#pragma once

#include <ros/ros.h>

#include <exception>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "autocal/stage.h"
#include "autocal/status_throttle.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/node_runtime.h"
#include "autocal_ros/params.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace ros_layer {

/// The private parameters every stage node has (doc/calibration_run.md "Nodes").
struct StageNodeOptions {
  std::string veh;  ///< default: the last component of the node's namespace
  std::string calibration_root = "/data/config/calibrations";
  /// Keep this stage's result when the run's last report says it succeeded and its file still
  /// exists (resumeStage).
  bool resume = false;
  double control_rate_hz = 50;  ///< [Hz]
  double connect_wait_s = 5.0;  ///< [wall s] for the inputs and the wheels' driver
  double status_rate_hz = 2.0;  ///< [Hz] RUNNING statuses between changes of step
  /// Start only after this stage's DONE on calibration/status (empty: at once); fail on its FAILED
  /// or after after_stage_wait_s [wall s, 0: no limit].
  std::string after_stage;
  double after_stage_wait_s = 0;
};

/// Reads the keys of StageNodeOptions that are set, all but after_stage and after_stage_wait_s (a
/// node that waits for a stage before it reads those), and validates them; ConfigError names the
/// first bad key.
StageNodeOptions readStageNodeOptions(const ParamReader& p, const ros::NodeHandle& nh,
                                      double min_control_rate_hz);

/// What the node's stage takes, fixed when the node is built.
struct StageInputs {
  std::string image_transport;  ///< "compressed" or "raw"; empty: no frames
  bool ranges = false;          ///< front_center_tof_driver_node/range
  bool pair_encoders = false;   ///< both wheels' counts at one instant (EncoderPairer)
  uint32_t queue_size = 50;     ///< encoder readings waiting per wheel
  /// > 0: the stage is built only at the first encoder reading (its resolution), waited for this
  /// long [wall s] after connecting; none is an InputError.
  double first_encoders_wait_s = 0;
};

class StageNode {
 public:
  /// Publishes "<stage>/wait" with `wait_text` at once.
  StageNode(ros::NodeHandle nh, std::string node_name, std::string stage,
            const StageNodeOptions& options, const StageInputs& inputs,
            const std::string& wait_text);

  /// Builds the stage; `ticks_per_revolution` is the encoders' (0 before the first reading).
  using Factory = std::function<std::unique_ptr<Stage>(int ticks_per_revolution)>;
  /// Hooks for what one node alone does; each may be empty.
  struct Hooks {
    /// The node's own inputs have publishers too (camera_info), beside the stage's.
    std::function<bool()> inputs_connected;
    /// After the inputs connected, before the stage is built (a wait for camera_info).
    std::function<void()> before_build;
    /// After the stage took a frame.
    std::function<void(double stamp_s, const cv::Mat& gray)> after_frame;
    /// After the file is written, before DONE (a service told); may add to the result.
    std::function<void(StageResult& result)> after_finish;
  };

  /// Resume, wait for the stage before, connect, build, drive until done, stop the wheels, finish
  /// and publish DONE. Returns early (no DONE) when interrupted; throws on failure.
  void run(const Factory& factory, const Hooks& hooks = {});

  /// ~resume: true when the last run's result of this stage is kept (its DONE published again),
  /// so that the stage need not run (resumeStage). run() asks it first.
  bool resumed();
  StatusPublisher& status() { return status_; }
  /// Where a callback keeps its exception for the loop to rethrow.
  std::exception_ptr* error() { return &error_; }
  /// Hands a measured input (a person's, or a helper's in the simulator) to the Stage from a
  /// callback: `give` when `awaited`, and its exception fails the stage at the loop's next step;
  /// otherwise a warning "<what> arrived while none is awaited: ignored". Returns whether it was
  /// given.
  bool hand(const std::string& what, bool awaited, const std::function<void()>& give);
  /// The DONE of ~after_stage (empty before).
  const CalibrationStatus& afterStageDone() const { return after_stage_done_; }
  /// Frames of another size are dropped (FrameInput::holdToSize).
  void holdFramesToSize(const cv::Size& size) {
    if (frames_) frames_->holdToSize(size);
  }

 private:
  /// The stage's inputs have publishers.
  bool inputsConnected() const;
  void subscribe(const Hooks& hooks);
  /// The latest encoder reading is given to the new stage.
  void build(const Factory& factory, int ticks_per_revolution);
  void publishStatus();
  /// The stage's end: its file written, DONE published.
  void finish(const Hooks& hooks);

  ros::NodeHandle nh_;
  std::string node_name_, stage_name_;
  StageNodeOptions options_;
  StageInputs inputs_;
  StatusPublisher status_;
  StatusThrottle throttle_;
  WheelsCommander wheels_;
  std::unique_ptr<Stage> stage_;
  std::unique_ptr<FrameInput> frames_;
  std::unique_ptr<EncoderInput> encoders_;
  ros::Subscriber range_sub_;
  ros::Publisher frames_used_;  ///< calibration/frames_used: the stamps of the frames taken
  EncoderPairer pairer_;
  Arrivals arrivals_;
  CalibrationStatus after_stage_done_;
  std::exception_ptr error_;
};

}  // namespace ros_layer
}  // namespace autocal
