// A recording (rosbag) of a robot's run, read with no master: opened with a clear error for each
// way a bag cannot be read, its topics listed, and the robot's messages of a calibration run given
// to a replay::RunReplay in the order they were received, as a live node got them.
#pragma once

#include <rosbag/bag.h>

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "autocal/odometry/uah_replay.h"
#include "autocal/replay/run_replay.h"

namespace autocal {
namespace ros_layer {

class Recording {
 public:
  /// Opens `path`; InputError naming the cause (no such file, not a bag, no index).
  explicit Recording(const std::string& path);
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;

  const std::string& path() const { return path_; }
  rosbag::Bag& bag() { return bag_; }
  bool has(const std::string& topic) const { return types_.count(topic) > 0; }
  /// Throws InputError unless every topic is in the recording, naming those missing and every
  /// topic it has ("is --veh NAME right?").
  void require(const std::vector<std::string>& topics, const std::string& veh) const;
  /// The robots in it: the namespaces of its calibration/status topics.
  std::vector<std::string> robots() const;
  /// The first and last record times [s].
  double beginS() const { return begin_s_; }
  double endS() const { return end_s_; }

 private:
  std::string path_;
  rosbag::Bag bag_;
  std::map<std::string, std::string> types_;  ///< topic: type
  double begin_s_ = 0, end_s_ = 0;
};

/// The stamps of the frames each stage of robot `veh` took, by stage: what its node published on
/// calibration/frames_used (std_msgs/Header: the frame's stamp, the stage's name). Empty when the
/// recording has none.
std::map<std::string, std::set<double>> framesUsed(Recording& recording, const std::string& veh);

/// The calibration stages ("camera", "wheels", "odometry", in run order) whose recorded statuses
/// of robot `veh` go past "<stage>/wait".
std::vector<std::string> recordedStages(Recording& recording, const std::string& veh);

/// What feedRecording read.
struct RecordingFeed {
  int messages = 0;
  int frames = 0;          ///< frames in the recording (of the transport read)
  int frames_decoded = 0;  ///< frames a stage wanted
  double end_s = 0;        ///< record time of the last message read
};

/// The messages of robot `veh` (its namespace: encoders, camera and camera_info, wheels_cmd,
/// calibration/status) in the order they were recorded, each with its header stamp (a stamp of 0:
/// its record time), given to `replay` until it ended or the recording did (then endOfRecording),
/// or `duration_s` of it [s, 0: all] were read. Frames come from camera_node/image/compressed, or
/// image/raw when there is none, and are decoded only when a stage wants them. `progress` is called
/// with the share of the recording read, every 1 % or so. Throws InputError for a bag that cannot
/// be read to its end or a topic of another type.
RecordingFeed feedRecording(Recording& recording, const std::string& veh, replay::RunReplay& replay,
                            double duration_s, const std::function<void(double share)>& progress);

/// What the UAH odometry stage needs of a recording of robot `veh`: its encoders, range readings,
/// wheels_cmd, calibration/status and the straight lengths given to it
/// (odometry_calibration_node/straight_length), each message at its header stamp (a stamp of 0:
/// see readUahRecording's comment), the encoders merged in stamp order; and the encoders'
/// resolution. Throws InputError naming a missing topic, a topic of another type, a bag that
/// cannot be read to its end, or a bag with no reading of both encoders.
struct UahBag {
  odometry::UahRecording recording;
  int ticks_per_revolution = 0;
};
UahBag readUahRecording(Recording& recording, const std::string& veh);

}  // namespace ros_layer
}  // namespace autocal
