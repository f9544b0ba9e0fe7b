// In-lane refinement of the wheel calibration (paper 000 §5.2), ROS-free: while the robot drives
// its lane under its usual controller, a straight lane segment with floor tags in the lane centre
// (6.5 cm, 15 cm apart, all co-directed with travel, the first one with a known id) refines the
// trim:
//   idle      nothing is commanded (the lane follower drives) until the first tag id is seen near
//             straight ahead; then a pass starts;
//   pass      the refiner owns the car command. It turns the robot coaxial with the tags (a short
//             ω correction while driving on), then drives straight for one tag spacing, fits the
//             heading change against the left wheel's angle over that straight part and gets the
//             ratio the wheels should have had (§3.4: k_i = 1 + Δθ·L/(R·φ_l)), re-orients, and so
//             on until the tags run out (the segment's end). Within a pass the straight parts are
//             driven with the pass's running estimate (a feed-forward ω through the kinematics
//             node's current trim), as the paper's robot "refines its wheel calibration
//             coefficient, applies it" at each marker, so the robot keeps straight even with a trim
//             far off;
//   apply     the pass's estimate (the median of its parts) is recorded; a new trim is returned
//             to the caller (who sets the kinematics node's parameter and saves the file) only
//             when the last `stable_passes` estimates agree within `stable_tolerance` and their
//             mean differs from the current trim by more than `apply_threshold` (§5.2: "applies
//             new values ... only when the new value is constant and significantly different from
//             the current one", so a random error never reaches the kinematics).
// Fail-safe: tags lost mid-pass (before the last id when the count is known), a heading beyond
// `max_heading_rad`, or a pass running too long aborts the pass: nothing is commanded any more,
// nothing recorded, back to idle.
//
// Beyond the paper: the tags lie on the lane centre, so the re-orientation aims not at heading 0
// but a little towards the centre line (lateral_gain_rad_per_m), which keeps the robot in its lane
// over a long segment; the heading change of a straight part is the least-squares slope of every
// frame's heading against the left wheel's angle, not the difference of two readings.
//
// The caller feeds stamps (sim time in the simulator), encoder readings and frames (or sightings),
// and sends the command update() returns; it never sees the truth.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/markers/tag_detector.h"
#include "autocal/wheels/kinematics.h"
#include "autocal/wheels/tag_heading.h"

namespace autocal {
namespace wheels {

struct LaneRefinerOptions {
  markers::TagDetectorOptions detector;
  HeadingOptions heading;  ///< its max_distance_m bounds the tags used in a pass
  CameraMount mount;
  /// The kinematics node's parameters in use (the trim the robot drives with now; gain, radius,
  /// baseline are the nominal R and L of §3.4's formula).
  KinematicsParams kinematics;

  /// The segment's tags: ids first_tag_id .. first_tag_id + num_tags − 1; num_tags 0 = any tag
  /// after the first (the segment's length unknown: losing the tags ends the pass).
  int first_tag_id = 100;
  int num_tags = 0;
  /// A pass starts when the first tag is seen within this distance [m], the robot's heading
  /// relative to it within start_max_heading_rad [rad] and its lateral offset from the tag line
  /// within start_max_lateral_m [m] (driving right in the lane).
  double start_max_distance_m = 0.5;
  double start_max_heading_rad = 0.3;
  double start_max_lateral_m = 0.08;
  /// Forward speed during a pass [m/s].
  double speed_mps = 0.2;
  /// Re-orientation: ω = heading_gain_per_s · (target − heading), at most max_omega_radps; done
  /// within orient_tolerance_rad [rad].
  double heading_gain_per_s = 3.0;
  double max_omega_radps = 1.0;
  double orient_tolerance_rad = 0.02;
  /// A re-orientation lasts at most this long [s]: a robot whose trim is far off turns by itself
  /// faster than a proportional correction can hold it at the target, so the straight part then
  /// starts where the robot points, and its measurement removes that turn from the next ones.
  double max_orient_s = 0.4;
  /// The target heading is −lateral_gain_rad_per_m · lateral offset, at most
  /// max_lateral_correction_rad (0 gain: coaxial with the tags, the paper's).
  double lateral_gain_rad_per_m = 2.0;
  double max_lateral_correction_rad = 0.1;
  /// A straight part: frames start settle_s after its command went out (the wheels' lag) [s]; it
  /// lasts straight_m of travel (one tag spacing) [m] or until the heading strays
  /// max_straight_deviation_rad from where it started [rad] (with the trim far off the first part
  /// is short, and the robot stays in its lane); it counts with at least min_frames_per_part
  /// frames over at least min_part_m of travel [m].
  double settle_s = 0.12;
  double straight_m = 0.15;
  double max_straight_deviation_rad = 0.06;
  int min_frames_per_part = 4;
  double min_part_m = 0.04;
  /// A part whose |k_i − 1| exceeds this is a mis-measurement and is dropped [1].
  double max_part_deviation = 0.35;
  /// A pass yields an estimate with at least this many parts.
  int min_parts_per_pass = 3;
  /// Fail-safe: |heading| above this aborts the pass [rad]; no pass tag for tags_lost_s [s] ends
  /// it (num_tags 0 or the last id seen) or aborts it; a pass longer than max_pass_s aborts [s].
  double max_heading_rad = 0.35;
  double tags_lost_s = 0.4;
  double max_pass_s = 30.0;
  /// Application (§5.2): the last stable_passes estimates agree within stable_tolerance [trim] and
  /// their mean differs from the current trim by more than apply_threshold [trim].
  int stable_passes = 3;
  double stable_tolerance = 0.005;
  double apply_threshold = 0.005;
  /// Without a lane follower (simulator tests): drive straight at speed_mps until the first pass
  /// starts.
  bool drive_to_first_tag = false;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

enum class LanePhase { kIdle, kOrient, kStraight };
const char* name(LanePhase phase);  ///< "idle", "orient", "straight"

/// One straight part of a pass.
struct LanePart {
  double commanded_ratio = 1;  ///< right/left nominal wheel-speed ratio it was driven with
  double delta_theta_rad = 0;  ///< fitted heading change over the part [rad]
  double left_angle_rad = 0;   ///< left wheel's turn over the part [rad]
  double k_i = 1;              ///< §3.4's factor
  double trim = 0;             ///< the trim that would have driven it straight
  int frames = 0;
  bool rejected = false;  ///< |k_i − 1| > max_part_deviation
};

/// One pass over the segment.
struct LanePass {
  double start_s = 0, end_s = 0;
  std::vector<LanePart> parts;
  bool aborted = false;
  std::string reason;      ///< why it aborted, or why it yielded no estimate
  bool estimated = false;  ///< enough parts: estimate is valid
  double estimate = 0;     ///< median of the accepted parts' trims
  bool applied = false;    ///< this pass made the refiner apply a new trim
};

/// What update() asks of the caller.
struct LaneOutput {
  bool commanding = false;  ///< send `cmd` now; false: send nothing (the lane follower drives)
  CarCommand cmd;
  bool apply = false;  ///< set the kinematics trim to `trim` and save it (once per application)
  double trim = 0;
};

class LaneRefiner {
 public:
  /// Throws ConfigError on bad options or intrinsics.
  LaneRefiner(const LaneRefinerOptions& options, const CameraIntrinsics& intrinsics);
  /// Without a camera: sightings are fed with addSightings (tests, recorded detections).
  explicit LaneRefiner(const LaneRefinerOptions& options);
  ~LaneRefiner();

  /// Cumulative ticks; stamps must not go back.
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution);
  /// Detects the tags of a frame (distorted, the intrinsics' size). Throws InputError on a bad
  /// image; ConfigError without a camera.
  void addFrame(double stamp_s, const cv::Mat& image);
  /// The tags of one frame, already in the robot frame.
  void addSightings(double stamp_s, const std::vector<TagSighting>& sightings);
  /// Advances; returns the command and, once per application, the new trim.
  LaneOutput update(double now_s);

  /// The trim the kinematics node uses now (after an application: the applied one). The caller
  /// sets it when the kinematics changed by other means (only between passes).
  double currentTrim() const { return trim_; }
  void setCurrentTrim(double trim);

  LanePhase phase() const { return phase_; }
  bool inPass() const { return phase_ != LanePhase::kIdle; }
  const std::vector<LanePass>& passes() const { return passes_; }
  /// The pass running now (or the last one, once it ended).
  const LanePass& currentPass() const { return pass_; }
  int applications() const { return applications_; }
  /// The last heading and lateral offset measured from the tags [rad], [m] (NaN before any).
  double lastHeadingRad() const { return last_heading_rad_; }
  double lastLateralM() const { return last_lateral_m_; }
  const std::vector<markers::TagDetection>& lastDetections() const { return last_detections_; }
  /// One line: phase, passes, current trim, the pass's running estimate.
  std::string describe() const;

 private:
  struct Sample {
    double stamp_s, heading_rad;
  };
  struct EncoderSample {
    double stamp_s, left_rad, right_rad;
  };

  bool isPassTag(int id) const;
  void startPass(double now_s);
  void startStraight(double now_s);
  void endPart();
  void endPass(double now_s, bool aborted, const std::string& reason);
  double leftAngleAt(double stamp_s) const;
  double meanWheelAngle() const;
  double passRatio() const;  ///< the ratio the straight parts are driven with
  double targetHeading() const;
  CarCommand straightCommand() const;
  LaneOutput finishOutput(LaneOutput out);

  LaneRefinerOptions options_;
  std::unique_ptr<markers::TagDetector> detector_;
  LanePhase phase_ = LanePhase::kIdle;
  double trim_ = 0;
  bool ever_started_ = false;
  bool pending_apply_ = false;
  int applications_ = 0;
  std::vector<LanePass> passes_;
  LanePass pass_;

  std::vector<EncoderSample> encoders_;  // the current pass's (and the last before it)
  bool have_frame_heading_ = false;
  double last_heading_rad_, last_lateral_m_;
  double last_heading_stamp_s_ = -1;
  double last_tag_s_ = -1;
  bool last_id_seen_ = false;
  std::vector<markers::TagDetection> last_detections_;

  double straight_cmd_s_ = 0;        // when the straight command went out
  double straight_start_wheel_ = 0;  // mean wheel angle when its window opened [rad]
  bool window_open_ = false;
  double part_ratio_ = 1;
  std::vector<Sample> samples_;
  double orient_start_s_ = 0;
  double straight_start_heading_ = 0;
};

}  // namespace wheels
}  // namespace autocal
