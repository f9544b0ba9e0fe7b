// The UAH calibration (paper 002 §2) recomputed from a recording of a run, no robot: the passive
// mode, as the `uah --bag` command runs it (doc/nodes/uah.md). It commands nothing. Which
// experiment each motion was comes from the recorded status (phase odometry/<experiment>),
// cross-checked against the recorded wheel commands (a pivot on the stopped left wheel commands
// left 0, right > 0; …); when each motion started and stopped comes from the commands (a motion is
// a stretch of commands not both zero), and its data ends when the encoders have settled after the
// stop, as odometry::UahRun ends it.
// Each turn's whole rounds are found again from the range autocorrelation over the turn (§2.1,
// detectWholeRound), the straight runs' pulses and heading from the encoders (§2.3), and the
// result is computeUah's with the same gates as the live run. The one measured input, each
// straight run's true length, is given (one for all runs, or one per run) or taken from the
// lengths recorded on the node's ~straight_length.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autocal/odometry/uah.h"
#include "autocal/odometry/uah_run.h"

namespace autocal {
namespace odometry {

/// What a bag of a UAH run holds, as plain samples (times in seconds, one clock).
struct UahRecording {
  struct Encoders {
    double stamp_s = 0;
    std::int32_t left = 0, right = 0;  ///< cumulative ticks once both wheels reported
  };
  struct Range {
    double stamp_s = 0, range_m = 0;
  };
  struct Command {
    double stamp_s = 0, left = 0, right = 0;  ///< duties
  };
  struct Status {
    double stamp_s = 0;
    std::string phase;  ///< e.g. "odometry/pivot_left_stopped"
    int state = 0;      ///< CalibrationStatus STATE_* (2 done, 3 failed)
    std::string failure_reason;
    double round = 0, straight_run = 0;
  };
  struct Length {
    double stamp_s = 0, length_m = 0;
  };
  std::vector<Encoders> encoders;
  std::vector<Range> ranges;
  std::vector<Command> commands;
  std::vector<Status> statuses;
  std::vector<Length> lengths;  ///< optional: the lengths given to the live node
};

struct UahReplayOptions {
  /// The live run's options: nominal robot, detection, gates (the defaults are the node's).
  UahRunOptions run;
  /// The straight runs' true lengths [m]: empty (the recorded ones), one (every run) or one per
  /// recorded straight run, in order.
  std::vector<double> straight_lengths_m;
  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// One motion of the recording.
struct UahReplayMotion {
  UahExperiment experiment = UahExperiment::kWait;
  double start_s = 0;      ///< first command of the motion
  double stop_s = 0;       ///< first zero command after it
  double end_s = 0;        ///< the encoders settled: the motion's data ends here
  int recorded_round = 0;  ///< highest round the recorded status reached (turns)
  int straight_run = 0;    ///< 1-based (straight runs)
};

struct UahReplayResult {
  std::vector<UahReplayMotion> motions;
  std::vector<UahTurn> turns;
  std::vector<StraightRun> straight_runs;
  /// "given" or "recorded": where the straight runs' lengths came from.
  std::string lengths_source;
  /// The recorded run's own end: "done", "failed: <reason>" or "unfinished".
  std::string recorded_outcome;
  double recording_s = 0;  ///< span of the recording
  /// Motions that ended before the first recorded odometry experiment: the earlier stages' (camera,
  /// wheels) in a recording of the whole run, left out.
  int earlier_stage_motions = 0;
  UahResult result;
};

/// Recomputes the UAH result from a recording. Throws InputError when the recording cannot carry
/// it (a sensor or the status missing, an encoder reset or jump, a motion whose commands contradict
/// the recorded experiment, a straight run without a length, lengths that do not match the runs)
/// and CalibrationError when the data do not determine the result (the live run's gates).
UahReplayResult replayUah(UahRecording recording, const UahReplayOptions& options);

}  // namespace odometry
}  // namespace autocal
