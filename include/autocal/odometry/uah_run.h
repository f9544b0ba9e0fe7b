// The UAH odometry calibration driven by the robot itself (paper 002 §2), ROS-free:
//   pivot_left_stopped   the right wheel drives, the robot pivots on its stopped left wheel; whole
//                        rounds are found by the range autocorrelation (§2.1, detectWholeRound),
//                        which also tells when to stop (after rounds + 1 detected rounds, so the
//                        robot faces where it started and `rounds` peaks enter the refinement);
//   pivot_right_stopped  the same on the stopped right wheel; both repeated pivot_experiments
//                        times give Ed (§2.2);
//   spin                 both wheels at the same pulse rate, opposite: the spin-in-place pulses
//                        per round give the wheelbase (§2.3);
//   face                 the turns end on whole rounds only as closely as they stop: each one's
//                        pulses over its own pulses per round say how far it turned past them, and
//                        when those fractions add up to more than face_tolerance_rad the robot
//                        pivots the long way round (a round less the sum) on one wheel, until it
//                        faces the heading it had when the stage began (the free line the straight
//                        runs need: a robot 18 deg off it rubbed a wall and came out 1.6 % short);
//   straight             straight runs of about straight_length_m (by the nominal right wheel),
//                        alternately forward and back on the same line, heading held by the
//                        encoders with the Ed just found; after each the caller gives the run's
//                        true start-to-end length (setStraightLength: measured by a person, or in
//                        the simulator by a ground-truth helper); runs whose heading strayed
//                        beyond the threshold are rejected and repeated, up to a bound (§2.3).
//                        A forward run goes faster over its second half: at each speed the
//                        duties are held at the heading hold's mean over a settling stretch while
//                        the pulses' slope measures how level they drive the wheels; the two
//                        speeds give the trim and deadbands (straightRunFit).
// The result is computeUah's. The caller feeds time, encoder readings and range readings and
// commands the duties update() returns; a motion's clock starts at the first update() that returns
// its duties. Failures throw CalibrationError (and the run stays failed with zero duties).
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "autocal/motion.h"
#include "autocal/odometry/dead_reckoning.h"
#include "autocal/odometry/uah.h"
#include "autocal/sensors.h"
#include "autocal/stage.h"
#include "autocal/wheels/kinematics.h"

namespace autocal {
namespace odometry {

/// The drive's options (EncoderDriveOptions) and the experiments'.
struct UahRunOptions : EncoderDriveOptions {
  /// The robot's parameters before the calibration: the expected pulses per round (§2.1's N_t)
  /// and the straight run's pulse target come from them.
  DiffDriveParams nominal;
  /// Whole rounds of each pivot or spin experiment that enter the correlation (the robot turns
  /// one more, see above).
  int rounds = 3;
  /// Pivot experiments per stopped wheel (§3.1: three iterations).
  int pivot_experiments = 2;
  /// Moving wheel's pulse rate while pivoting, and each wheel's while spinning [pulses/s]: a few
  /// pulses per range reading, so that the range profile is sampled densely on the pulse axis.
  double pivot_rate_pulses_per_s = 60.0;
  double spin_rate_pulses_per_s = 30.0;
  /// The right wheel's pulse rate on the straight runs [pulses/s].
  double straight_rate_pulses_per_s = 90.0;
  /// The forward runs' second half goes at this rate [pulses/s] (0: one rate throughout), so that
  /// each forward run holds the robot straight at two speeds: the duties of the two give each
  /// wheel's deadband besides the trim (straightRunFit). 240 (0.36 m/s on a Duckiebot): over 20
  /// drawn robots and 3 seeds of the core harness, 180 and 270 left more of them over 3 cm of
  /// drift (the two speeds' duties closer, or the fast one's noisier).
  double straight_fast_rate_pulses_per_s = 240.0;
  /// The straight run's rate rises from the spin's to its own over this time [s].
  double straight_ramp_s = 1.5;
  /// Straight runs: the distance to drive, by the nominal right wheel [m] (the free line needed);
  /// accepted runs wanted (forward and back in turn: 4 gives the trim and deadbands two forward
  /// runs' duties, whose noise alone drifted an ideal robot up to 3 cm in 2 m with one); extra
  /// runs allowed for rejected ones.
  double straight_length_m = 3.0;
  int straight_runs = 4;
  int max_straight_retries = 2;
  /// §2.3: runs whose heading strayed beyond this are rejected.
  StraightRunOptions straight;
  /// Heading hold on the straight runs: left duty += gain·(N_R − N_L/Ed) [duty/pulse], plus its
  /// integral [duty/(pulse·s)]. Gentle: a robot's readings and commands come 50-100 ms late, and
  /// twice these gains made its heading swing by a pulse either way (runs over 2 deg, on
  /// robot.yaml).
  double heading_gain_duty_per_pulse = 0.005;
  double heading_integral_duty_per_pulse_s = 0.015;
  /// Over a window at two speeds (StraightRunWindows) the duties are held at the settling
  /// stretch's means, and the left one moves only by this gain on the heading error's change
  /// since the hold began [duty/pulse]: slowly enough that each duty is paired with the speed it
  /// made, and enough that a settling mean a few % off does not take the heading out of its bound
  /// (held fixed, 3 of 13 drawn robots whose links were 50 ms late strayed over 5° or into a wall;
  /// with 0.001, 1 of 20, which also failed with the heading hold throughout).
  double held_heading_gain_duty_per_pulse = 0.001;
  /// A given length this far from the one the nominal pulses say means a cut-short run or a wrong
  /// measurement [fraction].
  double max_length_mismatch = 0.25;
  /// After the turns the robot pivots round until it faces its starting heading within this
  /// [rad] (a pivot pulse is about 0.8 deg on a Duckiebot), in at most max_face_turns turns; after
  /// them it goes on within three times this, and fails beyond.
  double face_tolerance_rad = 3.0 * M_PI / 180.0;
  int max_face_turns = 6;
  /// Forward straight runs stop and fail when a valid range reading is this close [m].
  double min_clearance_m = 0.12;
  /// The kinematics file the wheel stage wrote before this stage (<calibration_root>/kinematics/
  /// <veh>.yaml) gets the straight runs' trim, and at two speeds their deadbands
  /// (straightRunFit), when its trim differs from theirs by more than this (0: always). The wheel
  /// stage takes its trim from the floor tags' headings, and tags laid a degree or two turned bias
  /// it (11 of 20 drawn robots drifted over 3 cm in 2 m with it); the straight runs hold the
  /// heading by the encoders and Ed, which no tag enters. At two speeds, their duties held and
  /// levelled (StraightRunWindows), they drove the robustness matrix's 20 drawn robots within
  /// 3.6 cm in the core harness (at one speed up to 8.2 cm, through deadbands a few 0.0001 off).
  /// Negative: the file is never touched.
  double max_trim_disagreement = 0.0;
  /// §2.1 round detection (expected_pulses_per_round is set per experiment from `nominal`).
  RoundDetectionOptions detection;
  /// A turn whose valid range readings spread (standard deviation) less than this shows a circular
  /// or featureless scene: refused as such when no whole round is found [m].
  double min_range_spread_m = 0.02;
  /// A turn whose range autocorrelation takes more than this share of a round to fall below 0.3
  /// shows one smooth wave per round (a circular or symmetric scene seen off-centre): refused. The
  /// odometry world's turns take 0.07-0.11 of a round, the round wall's 0.21.
  double max_decorrelation_fraction = 0.15;
  /// Share of a turning experiment's range readings that may be dropouts or out of range.
  double max_invalid_range_fraction = 0.4;
  /// Silence of the range sensor (while turning) that fails the run [s].
  double range_timeout_s = 2.0;
  /// Bound of the whole run [s] (0: none) and of waiting for a straight run's length (0: none).
  double max_duration_s = 1200.0;
  double length_timeout_s = 0.0;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
  /// One line for a log: the experiments the run will drive.
  std::string summary() const;
};

enum class UahExperiment {
  kWait,
  kPivotLeftStopped,
  kPivotRightStopped,
  kSpin,
  kFace,
  kStraight,
  kDone,
  kFailed
};
/// "wait", "pivot_left_stopped", "pivot_right_stopped", "spin", "face", "straight", "done",
/// "failed".
const char* name(UahExperiment experiment);

/// One turning experiment's outcome.
struct UahTurn {
  UahExperiment experiment = UahExperiment::kWait;
  RoundDetection detection;
  double pulses_turned = 0.0;
  int range_readings = 0, invalid_readings = 0;
  /// Share of a round after which the range autocorrelation first falls below 0.3.
  double decorrelation_fraction = 0.0;
};

/// The odometry stage's file, live or replayed: writes odometryCalibrationPath(output) from
/// `result` (the quality gate first; throws on failure), with the DONE figures and log line;
/// `turns` are the stage's pivots and spin, `elapsed_s` its duration.
StageResult writeUahStageFile(const StageOutput& output, const UahResult& result,
                              const std::vector<UahTurn>& turns, double elapsed_s);

/// The trim with which the kinematics `params` (gain, deadbands) command the duties that held the
/// robot straight on the forward straight runs among `accepted` (indices into `runs`), their mean:
/// wheels::trimFromSpeedRatio of the right duty over the left one, each with its deadband removed
/// (equal commanded wheel speeds give duties in the ratio (gain + trim)/(gain − trim)). NaN when
/// no accepted forward run recorded its duties.
double straightRunTrim(const std::vector<StraightRun>& runs, const std::vector<int>& accepted,
                       const wheels::KinematicsParams& params);

/// What the forward straight runs say the kinematics file should hold.
struct StraightRunFit {
  double trim = std::numeric_limits<double>::quiet_NaN();
  /// Runs at two speeds: each wheel's deadband fitted too (their mean kept); else the file's.
  bool two_speeds = false;
  double deadband_left = 0, deadband_right = 0;
};

/// At one speed, straightRunTrim. At two (UahRunOptions::straight_fast_rate_pulses_per_s), the
/// trim and the deadbands with which `params` command both speeds' duties that held the robot
/// straight: a deadband off by 0.0005 turns a robot at 0.15 m/s as a trim 0.001 off does, and a
/// trim fitted at one speed takes that error in, right there and wrong at the others. Falls back
/// to one speed where the two give no line through the deadbands (a negative deadband, a duty
/// below its deadband).
StraightRunFit straightRunFit(const std::vector<StraightRun>& runs,
                              const std::vector<int>& accepted,
                              const wheels::KinematicsParams& params);

/// What the odometry stage does to the kinematics file's trim.
struct TrimRefinement {
  bool compared = false;  ///< a kinematics file and an accepted forward run were there
  bool replace = false;   ///< the file is to get the straight runs' trim
  bool written = false;   ///< the file got it
  double file_trim = 0, straight_trim = 0;
  /// The straight runs went at two speeds: the deadbands they give are replaced with the trim.
  bool deadbands = false;
  wheels::KinematicsParams params;  ///< the file's, with the trim (and deadbands) it is to have
  wheels::KinematicsParams before;  ///< the file's as read
};

/// The turn per metre [rad/m, counter-clockwise] of a robot driving forward at `speed_mps` with
/// the duties `driven` gives for straight, where `truth` is right: the wheel speeds `truth` says
/// those duties make, their difference over their mean and `wheelbase_m`.
double straightTurnPerM(const wheels::KinematicsParams& driven,
                        const wheels::KinematicsParams& truth, double speed_mps,
                        double wheelbase_m);

/// Compares the trim of the kinematics file at `path`, if it exists, with the straight runs'
/// (straightRunTrim with the file's gain and deadbands): `replace` when they differ by more than
/// `max_disagreement` (negative: never). Reads only. Throws ConfigError or IoError for a file that
/// cannot be read.
TrimRefinement planTrimRefinement(const std::string& path, const std::vector<StraightRun>& runs,
                                  const std::vector<int>& accepted, double max_disagreement);

/// Writes a planned replacement (`plan.replace`) into the kinematics file at `path`, every other
/// key kept, and sets `plan.written`. Atomically; an existing `.prev` stays (in a run, the file
/// from before the wheel stage), else the file replaced becomes it. Throws IoError.
void writeTrimRefinement(const std::string& path, TrimRefinement& plan);

/// planTrimRefinement, then writeTrimRefinement.
TrimRefinement refineKinematicsTrim(const std::string& path, const std::vector<StraightRun>& runs,
                                    const std::vector<int>& accepted, double max_disagreement);

/// The odometry stage's end, live or replayed: the kinematics file the wheel stage wrote
/// (<calibration_root>/kinematics/<veh>.yaml) is read first (one that cannot be read fails the
/// stage before it writes anything; `max_trim_disagreement` negative: it is not read), then the
/// stage's file is written (writeUahStageFile), then the kinematics file's trim is replaced where
/// planTrimRefinement says so. The DONE figures add straight_run_trim and kinematics_trim where
/// they were compared; the text says a replacement. Where the trim was replaced and the wheel
/// stage wrote the camera's extrinsics (<calibration_root>/camera_extrinsic/<veh>.yaml, with
/// extrinsics::kYawPerTurnKey), its mount is corrected for the turn its hops made with the wheel
/// stage's kinematics (straightTurnPerM at extrinsics::kStraightSpeedKey, the wheelbase found
/// here; extrinsics::correctForStraightTurn, through the camera_intrinsic file) and the DONE
/// figures add extrinsics_yaw_change_rad.
StageResult finishUahStage(const StageOutput& output, const UahResult& result,
                           const std::vector<UahTurn>& turns, double elapsed_s,
                           const std::vector<StraightRun>& straight_runs,
                           double max_trim_disagreement);

class UahRun : public Stage {
 public:
  /// Throws ConfigError on bad options.
  explicit UahRun(const UahRunOptions& options);

  /// Cumulative ticks (wrapping 32-bit counts are unwrapped). Throws CalibrationError on a reset or
  /// jump. Stamps going back are dropped.
  /// The resolution is the nominal's (ticks_per_revolution and now_s are not used).
  void addEncoders(double stamp_s, int left_ticks, int right_ticks, int ticks_per_revolution = 0,
                   double now_s = 0) override;
  /// A range reading (REP 117: ±inf, NaN, out of range are dropouts).
  void addRange(double stamp_s, double range_m) override;
  /// Whether the run waits for the true length of the straight run just driven.
  bool needsStraightLength() const { return awaiting_length_; }
  /// The true start-to-end length of that run [m]. Throws InputError when none is awaited or the
  /// length is not a positive number, CalibrationError when it contradicts the pulses.
  void setStraightLength(double length_m);
  /// Advances the run; returns the duties to command now (zero when done or failed).
  WheelDuties update(double now_s) override;

  UahExperiment experiment() const { return experiment_; }
  bool done() const override { return experiment_ == UahExperiment::kDone; }
  bool failed() const { return experiment_ == UahExperiment::kFailed; }
  const std::string& failure() const { return failure_; }
  /// Valid once done().
  const UahResult& result() const { return result_; }
  const std::vector<UahTurn>& turns() const { return turns_; }
  const std::vector<StraightRun>& straightRuns() const { return straight_runs_; }
  /// The straight run under way or waiting for its length: 1-based, and the time its duties first
  /// went out [s] (the robot stood still until then: a ground-truth helper measures from there).
  int straightRun() const { return attempts_ + 1; }
  double straightRunStartS() const { return drive_.clock().startS(); }
  /// The round the current turn is in (1-based; 0 before a round is detected), the latest pulses
  /// per round of the current turn (0 until detected).
  int round() const;
  double pulsesPerRound() const { return online_ppr_; }
  /// 0..1, a rough share of the run done.
  double progress() const;
  double elapsedS() const { return drive_.elapsedS(); }
  /// Turns back to the starting heading made after the spin (see `face`).
  int faceTurns() const { return face_turns_; }
  /// One line: experiment, counts, last figures.
  std::string describe() const;
  /// Step: the experiment; key: round, straight run, the wait for its length, face turn.
  StageStatus status() const override;
  /// Writes <calibration_root>/odometry/<veh>.yaml (its quality gate first); valid once done().
  StageResult finish(const StageOutput& output) override;

 private:
  enum class Motion { kNone, kTurn, kDrive, kSettle };

  [[noreturn]] void fail(const std::string& why);
  void startTurn(UahExperiment experiment, double now_s);
  void startStraight(double now_s);
  /// After the spin: a face turn when the turns left the robot off its starting heading, else the
  /// straight runs.
  void faceOrStraight(double now_s);
  WheelDuties updateFace(double now_s, double dt_s);
  /// The face turn's pulses per round: the mean of the pivots on the wheel it stops.
  double facePulsesPerRound() const;
  /// coast_s_'s entry for the turn under way.
  int coastIndex() const;
  void stop(double now_s);
  /// One control step of a turn (pivots and the spin, §2.1) or of a straight run (§2.3).
  WheelDuties updateTurn(double now_s, double dt_s);
  WheelDuties updateStraight(double now_s, double dt_s);
  /// A driven wheel's duty towards a pulse rate; FAILED when the wheel stalls.
  void follow(int side, double target_pulses_per_s, double dt_s);
  void checkStall(int side, double now_s);
  void onSettled(double now_s);
  void finishTurn();
  void finishStraight(double length_m);
  void nextAfterTurns(double now_s);
  void finish();
  double turnPulses(const EncoderDrive::Sample& s) const;
  std::vector<RangeSample> turnRangeSamples() const;
  RoundDetectionOptions detectionFor(UahExperiment experiment) const;
  /// Standard deviation of the current turn's valid range readings [m].
  double rangeSpreadM() const;
  /// The current turn's decorrelation_fraction (see UahTurn).
  double decorrelationFraction() const;
  /// Fails with the circular-scene reason when the ranges barely vary.
  void refuseFlatScene();
  DiffDriveParams headingParams() const;

  UahRunOptions options_;
  UahExperiment experiment_ = UahExperiment::kWait;
  Motion motion_ = Motion::kNone;
  std::string failure_;
  UahResult result_;

  /// The run's clock, the encoders, the current motion's samples and clock, the wheels' duties.
  EncoderDrive drive_;
  const EncoderTracker& encoders() const { return drive_.encoders(); }
  double last_range_arrival_s_ = 0;

  // motion
  WheelDuties duties_;
  double start_left_ = 0, start_right_ = 0;

  // turning
  int pivot_done_[2] = {0, 0};  // experiments done with the left / right wheel stopped
  std::vector<std::array<double, 2>> ranges_;  // stamp, range
  int invalid_ranges_ = 0;
  double online_ppr_ = 0, next_check_pulses_ = 0, turn_target_pulses_ = 0;
  // A turn ends on whole rounds, so that the robot faces where it did before (the face turn makes
  // up what is left): it stops early by the time the last turn of its kind coasted on after its
  // stop [s] (the wheels' lag, and on a robot the commands' and the readings' delays): the left
  // wheel's pivots (right one stopped), the right wheel's, the spin (coastIndex()). Where and at
  // which rate the last stop was decided.
  double coast_s_[3] = {0.05, 0.05, 0.05}, stop_pulses_ = 0, stop_rate_ = 0;
  std::string last_detection_error_;
  std::vector<double> right_ppr_left_stopped_, left_ppr_right_stopped_;
  double Ed_ = 1.0;
  double spin_ppr_ = 0;
  std::vector<UahTurn> turns_;
  double spin_duty_[2] = {0, 0};
  /// The heading against the stage's start, from each turn's pulses over its pulses per round
  /// (counter-clockwise positive) [rad]; the face turn under way: its direction (+1
  /// counter-clockwise), its target on the spin's pulse axis, the turns made.
  double heading_rad_ = 0;
  int face_dir_ = 1, face_turns_ = 0;
  double face_target_pulses_ = 0;

  // straight
  int straight_dir_ = 1;
  int accepted_ = 0, attempts_ = 0;
  double heading_integral_ = 0;
  double max_heading_dev_rad_ = 0;
  bool awaiting_length_ = false;
  double awaiting_since_s_ = 0;
  double run_right_pulses_ = 0, run_max_dev_rad_ = 0, run_shortening_ = 0;
  double run_duty_sum_[2] = {0, 0};  ///< left, right over the run's window at its (first) rate
  int run_duty_count_ = 0;
  double fast_duty_sum_[2] = {0, 0};  ///< left, right over the window at the fast rate
  int fast_duty_count_ = 0;
  double fast_since_s_ = -1;  ///< when the forward run went over to the fast rate (<0: not yet)
  /// Each window's left pulses against its right ones (from the run's start).
  PulseLine slow_pulses_, fast_pulses_;
  /// Duties (left, right) summed over the settling stretch before each window, and held there.
  double settle_sum_[2] = {0, 0};
  int settle_count_ = 0;
  double held_[2] = {0, 0};
  bool holding_ = false;
  double hold_since_s_ = 0;  ///< when the duties were fixed
  double hold_error_ = 0;  ///< the heading error when they were
  std::vector<StraightRun> straight_runs_;
};

}  // namespace odometry
}  // namespace autocal
