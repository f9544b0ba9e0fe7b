// The sweep of the camera calibration (paper 000 §3.2): the robot turns in small steps past the
// chessboards standing in a semicircle around it, several passes from one extreme board to the
// other, and collects views until the coverage is sufficient.
//
// The state is the paper's: the board being viewed (numbered counter-clockwise from 0), the turn
// direction, whether a board is in the frame, and whether the robot is in recovery mode (no board
// in the frame, but it knows which way the next or the last board is). The paper is told the
// number of boards and the board in view at the start; here both are optional and, when missing,
// found in a first pass (see SweepOptions::board_count).
//
// The node calls decide() once per settled frame and executes the returned step; it does the
// timing (SweepOptions::step_duration_s, settle_s) and owns the view collector.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "autocal/camera/wheel_turn.h"

namespace autocal {
namespace camera {

struct SweepOptions {
  // --- the layout (paper 000 §3.1) -------------------------------------------------------------
  /// Number of boards around the robot; 0 = unknown: the first pass counts them. When given and the
  /// first pass runs anyway (start_board unknown), a different count is a failure.
  int board_count = 0;
  /// Board in view (nearest the image centre) at the start, numbered counter-clockwise from 0;
  /// -1 = unknown: found in the first pass. Without board_count the first pass runs anyway and a
  /// different start board is a failure. With both given but no board in view at the start, the
  /// first pass runs too (and checks board_count only).
  int start_board = -1;
  /// First turn direction (paper §3.2: "for definiteness, it is assumed to be clockwise").
  TurnDirection initial_direction = TurnDirection::kCw;
  /// Full passes from one extreme board to the other; the sweep fails when the last one ends
  /// without sufficient coverage. The leg from the start board to the first extreme board does not
  /// count; a first pass that counts the boards does.
  int max_passes = 3;
  /// Steps before sufficient coverage may end the sweep: a frame holding a standing board and one
  /// on the floor can satisfy the coverage measures within a few steps, from views of one part of
  /// the area.
  int min_steps = 20;

  // --- geometry ---------------------------------------------------------------------------------
  /// Horizontal field of view of the camera [rad], nominal (2·atan(width / (2·fx)) from
  /// camera_info): turns a heading change into an expected shift of the boards in the image.
  double camera_hfov_rad = 1.5708;
  /// Largest turn [rad] with no board in the frame between two neighbouring boards. Turning this
  /// far past a board without finding another means it was an extreme board; must be smaller than
  /// the empty arc outside the extreme boards (about 2π − board arc − field of view).
  double max_gap_rad = 1.2;
  /// A full revolution by the encoders [rad]: no board in a turn this long is a failure, and so is
  /// a first-pass leg this long (boards all around). 2π plus 10 %: the heading comes from wheels
  /// that are not calibrated yet (nominal radius and wheelbase).
  double full_turn_rad = 6.9;
  /// A board in this frame is the same as one in the previous frame when its centre x is within
  /// this of the previous x shifted by the turn [1, image widths].
  double track_gate = 0.12;
  /// A board lost within this of the trailing image edge (the edge boards leave by) has left the
  /// frame; lost further in, it is a detection drop-out and is expected back [1, image widths].
  double trailing_margin = 0.3;
  /// A board that vanished is taken as gone (past an extreme board: reverse) only after this many
  /// frames in a row without a board: a detection can miss a board in a single frame.
  int lost_confirm_frames = 2;

  // --- budgets ----------------------------------------------------------------------------------
  /// Recovery steps allowed before the sweep fails (the angle budget is max_gap_rad).
  int max_recovery_steps = 200;
  /// Decisions allowed in all before the sweep fails.
  int max_steps = 3000;
  /// A step that turned less than this [rad] did not move; max_stalled_steps of them in a row
  /// are a failure (wheel blocked, duty below the deadband, encoders silent).
  double min_step_rad = 0.002;
  int max_stalled_steps = 15;

  // --- stepping (the node's timing, paper §3.2) -------------------------------------------------
  /// Which wheel stands still.
  PivotConvention pivot = PivotConvention::kPivotRight;
  /// Length of one duty pulse [s] (paper: a quantum of 0.1 s).
  double step_duration_s = 0.1;
  /// Duty of a pulse above the wheel's minimum moving duty (MinDutyProbe) [1].
  double step_duty_margin = 0.02;
  /// Wait after the wheel stops before a frame is grabbed [s].
  double settle_s = 0.3;
  /// Longest wait for a sharp frame after a step [s]; after it the frame is used as it is.
  double max_settle_s = 1.0;

  /// Throws ConfigError naming the first bad key.
  void validate() const;
};

/// What the node saw after a step (one settled frame).
struct SweepObservation {
  /// Centre x of every board found in the frame, normalised to [0, 1] (0 = left edge), e.g.
  /// ViewParams::x of each FrameResult decision. Its size is the number of boards found.
  std::vector<double> boards_x;
  /// A view of this frame was kept by the view collector.
  bool view_kept = false;
  /// ViewCollector::coverage().sufficient after this frame.
  bool coverage_sufficient = false;
  /// Heading change since the previous observation [rad], + = counter-clockwise, estimated from the
  /// encoders (0 for the first observation).
  double turned_rad = 0;
};

enum class SweepAction { kTurn, kDone, kFailed };

struct SweepDecision {
  SweepAction action = SweepAction::kTurn;
  TurnDirection direction = TurnDirection::kCw;  ///< the step to make, for kTurn
  std::string reason;                            ///< why it ended, for kDone and kFailed
  bool turn() const { return action == SweepAction::kTurn; }
};

enum class SweepPhase {
  kDiscoverFirst,   ///< first leg of the first pass: turning until past an extreme board
  kDiscoverSecond,  ///< back over all boards to the other extreme, counting them
  kSweep,           ///< passes over the known boards
  kDone,
  kFailed,
};
const char* name(SweepPhase phase);

class SweepController {
 public:
  /// Throws ConfigError when the options are invalid.
  explicit SweepController(const SweepOptions& options);

  /// One step of the paper's loop (§3.2, Figure 2): takes what the last settled frame showed and
  /// says which way to make the next step, or that the sweep is over. After kDone or kFailed it
  /// returns the same decision. Throws InputError on a non-finite turn or an x outside [0, 1].
  SweepDecision decide(const SweepObservation& observation);

  SweepPhase phase() const { return phase_; }
  bool finished() const { return phase_ == SweepPhase::kDone || phase_ == SweepPhase::kFailed; }
  /// The board being viewed (nearest the image centre, or the last one seen), numbered
  /// counter-clockwise from 0; -1 while the boards are not known yet.
  int board() const;
  /// The board recovery is turning toward (-1 when not in recovery or not known).
  int recoveryTarget() const;
  TurnDirection direction() const { return direction_; }
  bool inFrame() const { return in_frame_; }
  bool recovery() const { return recovery_; }
  /// Current pass: 0 the leg from the start board to the first extreme (or the first leg of the
  /// discovery), 1..max_passes the full passes.
  int pass() const { return pass_; }
  bool boardsKnown() const {
    return count_ > 0 && phase_ != SweepPhase::kDiscoverFirst &&
           phase_ != SweepPhase::kDiscoverSecond;
  }
  /// Number of boards (0 while unknown).
  int boardCount() const { return boardsKnown() ? count_ : 0; }
  /// Board in view at the start (-1 while unknown or when none was in view).
  int startBoard() const;
  int steps() const { return steps_; }
  /// Sum of the turns reported so far [rad], + = counter-clockwise.
  double headingRad() const { return heading_rad_; }
  /// Views kept while each board was the one being viewed (index = board; empty while unknown).
  std::vector<int> viewsPerBoard() const;
  /// One line for status messages, e.g. "pass 2/3, board 3/5, turning ccw, board in frame".
  std::string describe() const;

 private:
  struct Tracked {
    double x;
    int ordinal;
  };
  struct Lost {
    bool active = false;
    int ordinal = 0;  ///< the board nearest the direction of travel when the frame emptied
    double x = 0;     ///< where that board is now expected in the image (may be outside)
    TurnDirection direction = TurnDirection::kCw;  ///< direction of travel when it was lost
    double heading_rad = 0;                        ///< heading when it was lost
    int frames = 0;                                ///< frames without a board since
  };

  void track(const std::vector<double>& xs, double shift);
  SweepDecision whileLost();
  SweepDecision endOfLeg();
  bool finishDiscovery(std::string* failure);
  SweepDecision turn();
  SweepDecision done(const std::string& reason);
  SweepDecision fail(const std::string& reason);
  /// The lost board has left by the trailing edge (not a drop-out): confirmed over frames.
  bool lostBoardLeftFrame() const;
  int index(int ordinal) const { return ordinal - offset_; }
  std::string boardName(int ordinal) const;

  SweepOptions options_;
  SweepPhase phase_;
  SweepDecision final_;
  TurnDirection direction_;
  bool in_frame_ = false;
  bool recovery_ = false;
  int pass_ = 0;
  int count_ = 0;   ///< number of boards (given, or counted by the discovery)
  int offset_ = 0;  ///< ordinal of board 0 (ordinals are relative during the discovery)
  int steps_ = 0;
  double heading_rad_ = 0;
  bool turned_last_ = false;
  int stalled_steps_ = 0;

  std::vector<Tracked> frame_;  ///< boards of the last frame with a board
  int board_ = 0;               ///< ordinal of the board being viewed
  bool seen_any_ = false;
  bool start_in_view_ = false;  ///< a board was in the first frame (its ordinal is start_ordinal_)
  int start_ordinal_ = 0;
  int ord_min_ = 0, ord_max_ = 0;
  Lost lost_;
  double recovery_start_heading_rad_ = 0;
  double recovery_budget_rad_ = 0;
  int recovery_steps_ = 0;
  double leg_start_heading_rad_ = 0;
  bool leg_start_pending_ = true;  ///< a leg starts where its first board comes (back) in
  std::map<int, int> views_;       ///< views kept per ordinal (while it was the one being viewed)
};

}  // namespace camera
}  // namespace autocal
