// The sweep controller of paper 000 §3.2 (state and transitions of its Figure 2), with the number
// of boards and the start board found in a first pass when they are not given.
//
// How boards are told apart: the boards stand in a semicircle numbered counter-clockwise, so in a
// frame they appear in order — the rightmost has the lowest number. A turn of Δθ moves every board
// by about Δθ / hfov image widths (to the right on a counter-clockwise turn), so a board of the
// previous frame is found again near its shifted position and keeps its number; a board that is
// new takes its number from its rank next to a known one. When the frame empties, the board
// nearest the direction of travel is remembered with its expected position: if it left by the
// trailing edge the robot is between boards (keep turning: the next board enters by the leading
// edge) or past the extreme board (reverse: the same board comes back) — the paper's recovery mode;
// if it vanished in mid-frame it was a detection drop-out and is expected back where it was.
#include "autocal/camera/sweep_controller.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "autocal/errors.h"

namespace autocal {
namespace camera {

namespace {

std::string fmt(double v, int precision = 2) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(precision);
  s << v;
  return s.str();
}

}  // namespace

void SweepOptions::validate() const {
  checkConfig(board_count >= 0, "board_count",
              "must be >= 0 (0 = count the boards in a first pass)");
  checkConfig(start_board >= -1, "start_board", "must be >= 0, or -1 = find it in a first pass");
  checkConfig(board_count == 0 || start_board < board_count, "start_board",
              "must be below board_count (boards are numbered from 0)");
  checkConfig(max_passes >= 1, "max_passes", "must be >= 1");
  checkConfig(min_steps >= 0, "min_steps", "must be >= 0");
  checkConfig(std::isfinite(camera_hfov_rad) && camera_hfov_rad > 0 && camera_hfov_rad < M_PI,
              "camera_hfov_rad", "must be in (0, pi)");
  checkConfig(std::isfinite(full_turn_rad) && full_turn_rad > 0, "full_turn_rad", "must be > 0");
  checkConfig(std::isfinite(max_gap_rad) && max_gap_rad > 0 && max_gap_rad < full_turn_rad,
              "max_gap_rad", "must be in (0, full_turn_rad)");
  checkConfig(std::isfinite(track_gate) && track_gate > 0 && track_gate < 0.5, "track_gate",
              "must be in (0, 0.5)");
  checkConfig(std::isfinite(trailing_margin) && trailing_margin > 0 && trailing_margin < 0.5,
              "trailing_margin", "must be in (0, 0.5)");
  checkConfig(lost_confirm_frames >= 1, "lost_confirm_frames", "must be >= 1");
  checkConfig(max_recovery_steps >= 1, "max_recovery_steps", "must be >= 1");
  checkConfig(max_steps >= 1, "max_steps", "must be >= 1");
  checkConfig(std::isfinite(min_step_rad) && min_step_rad >= 0, "min_step_rad", "must be >= 0");
  checkConfig(max_stalled_steps >= 1, "max_stalled_steps", "must be >= 1");
  checkConfig(std::isfinite(step_duration_s) && step_duration_s > 0, "step_duration_s",
              "must be > 0");
  checkConfig(std::isfinite(step_duty_margin) && step_duty_margin >= 0 && step_duty_margin < 1,
              "step_duty_margin", "must be in [0, 1)");
  checkConfig(std::isfinite(settle_s) && settle_s >= 0, "settle_s", "must be >= 0");
  checkConfig(std::isfinite(max_settle_s) && max_settle_s >= settle_s, "max_settle_s",
              "must be >= settle_s");
}

const char* name(SweepPhase phase) {
  switch (phase) {
    case SweepPhase::kDiscoverFirst:
      return "discover_first";
    case SweepPhase::kDiscoverSecond:
      return "discover_second";
    case SweepPhase::kSweep:
      return "sweep";
    case SweepPhase::kDone:
      return "done";
    case SweepPhase::kFailed:
      return "failed";
  }
  return "?";
}

SweepController::SweepController(const SweepOptions& options)
    : options_(options), direction_(options.initial_direction) {
  options_.validate();
  // Told both (as the paper is): board 0 is ordinal 0 and the first frame shows start_board.
  const bool known = options_.board_count > 0 && options_.start_board >= 0;
  phase_ = known ? SweepPhase::kSweep : SweepPhase::kDiscoverFirst;
  count_ = known ? options_.board_count : 0;
}

int SweepController::board() const {
  if (!boardsKnown() || !seen_any_) return -1;
  return index(board_);
}

int SweepController::recoveryTarget() const {
  if (!recovery_ || !boardsKnown() || !lost_.active) return -1;
  if (direction_ != lost_.direction || !lostBoardLeftFrame()) return index(lost_.ordinal);
  const int next = index(lost_.ordinal + sign(direction_));
  return next >= 0 && next < count_ ? next : index(lost_.ordinal);  // past an extreme: turn back
}

int SweepController::startBoard() const {
  if (!boardsKnown() || !start_in_view_) return -1;
  return index(start_ordinal_);
}

std::vector<int> SweepController::viewsPerBoard() const {
  if (!boardsKnown()) return {};
  std::vector<int> v(count_, 0);
  for (const auto& kv : views_) {
    const int i = index(kv.first);
    if (i >= 0 && i < count_) v[i] += kv.second;
  }
  return v;
}

std::string SweepController::boardName(int ordinal) const {
  if (boardsKnown()) return "board " + std::to_string(index(ordinal));
  // Before the first pass has counted the boards, ordinals count them from the first one seen,
  // one up per board in the direction of a left (counter-clockwise) turn.
  if (ordinal == 0) return "the first board seen";
  const int n = std::abs(ordinal);
  return std::to_string(n) + (n == 1 ? " board " : " boards ") + (ordinal > 0 ? "left" : "right") +
         " of the first one seen";
}

std::string SweepController::describe() const {
  std::ostringstream s;
  switch (phase_) {
    case SweepPhase::kDiscoverFirst:
      s << "first pass, looking for an extreme board";
      break;
    case SweepPhase::kDiscoverSecond:
      s << "first pass, counting boards (" << (ord_max_ - ord_min_ + 1) << " so far)";
      break;
    case SweepPhase::kSweep:
      s << "pass " << pass_ << "/" << options_.max_passes;
      break;
    case SweepPhase::kDone:
    case SweepPhase::kFailed:
      return std::string(name(phase_)) + ": " + final_.reason;
  }
  if (seen_any_) {
    s << ", " << boardName(board_);
    if (boardsKnown()) s << "/" << count_;
  } else {
    s << ", no board seen yet";
  }
  s << ", turning " << name(direction_);
  if (in_frame_) {
    s << ", board in frame";
  } else if (recovery_) {
    const int target = recoveryTarget();
    s << ", recovery";
    if (target >= 0) s << " toward board " << target;
  }
  return s.str();
}

SweepDecision SweepController::turn() {
  turned_last_ = true;
  SweepDecision d;
  d.action = SweepAction::kTurn;
  d.direction = direction_;
  return d;
}

SweepDecision SweepController::done(const std::string& reason) {
  phase_ = SweepPhase::kDone;
  final_ = SweepDecision{SweepAction::kDone, direction_, reason};
  return final_;
}

SweepDecision SweepController::fail(const std::string& reason) {
  phase_ = SweepPhase::kFailed;
  final_ = SweepDecision{SweepAction::kFailed, direction_, reason};
  return final_;
}

bool SweepController::lostBoardLeftFrame() const {
  // Boards leave by the right edge on a counter-clockwise turn and by the left edge on a clockwise
  // one (the image content moves against the turn).
  const bool trailing = lost_.direction == TurnDirection::kCcw
                            ? lost_.x >= 1.0 - options_.trailing_margin
                            : lost_.x <= options_.trailing_margin;
  return trailing && lost_.frames >= options_.lost_confirm_frames;
}

void SweepController::track(const std::vector<double>& xs_in, double shift) {
  if (xs_in.empty()) {
    if (!frame_.empty()) {
      // The frame just emptied: remember the board nearest the direction of travel — the one
      // recovery turns toward or past (§3.2 "knows where to move in order to find it").
      const bool ccw = direction_ == TurnDirection::kCcw;
      const Tracked* lead = &frame_.front();
      for (const Tracked& t : frame_) {
        if (ccw ? t.ordinal > lead->ordinal : t.ordinal < lead->ordinal) lead = &t;
      }
      lost_.active = true;
      lost_.ordinal = lead->ordinal;
      lost_.x = lead->x + shift;
      lost_.direction = direction_;
      lost_.heading_rad = heading_rad_;
      lost_.frames = 1;
      recovery_start_heading_rad_ = heading_rad_;
      recovery_budget_rad_ = options_.max_gap_rad;
      recovery_steps_ = 0;
      frame_.clear();
    } else if (lost_.active) {
      lost_.x += shift;
      ++lost_.frames;
    }
    in_frame_ = false;
    return;
  }

  // Rightmost first: boards are numbered counter-clockwise, so the ordinal grows with the rank.
  std::vector<double> xs = xs_in;
  std::sort(xs.begin(), xs.end(), std::greater<double>());
  const int n = static_cast<int>(xs.size());
  std::vector<int> ord(n, 0);
  std::vector<bool> known(n, false);

  if (!frame_.empty()) {
    // Same boards as the last frame: greedy one-to-one matching on the shifted positions.
    struct Candidate {
      double distance;
      int i, j;
    };
    std::vector<Candidate> candidates;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < static_cast<int>(frame_.size()); ++j) {
        const double d = std::abs(xs[i] - (frame_[j].x + shift));
        if (d <= options_.track_gate) candidates.push_back({d, i, j});
      }
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
    std::vector<bool> used(frame_.size(), false);
    for (const Candidate& c : candidates) {
      if (known[c.i] || used[c.j]) continue;
      known[c.i] = true;
      used[c.j] = true;
      ord[c.i] = frame_[c.j].ordinal;
    }
  }
  if (std::none_of(known.begin(), known.end(), [](bool k) { return k; })) {
    if (lost_.active) {
      lost_.x += shift;
      // A drop-out, or the board recovery turned back to, seen again where it is expected.
      int best = -1;
      for (int i = 0; i < n; ++i) {
        const double d = std::abs(xs[i] - lost_.x);
        if (d <= options_.track_gate && (best < 0 || d < std::abs(xs[best] - lost_.x))) best = i;
      }
      if (best < 0) {
        // Recovery (§3.2): turned back past an extreme, the board that comes in is the lost one;
        // still turning the same way, it is the next one. The first to come in is the one
        // farthest from the leading edge (boards enter on the left on a counter-clockwise turn).
        const bool reversed = direction_ != lost_.direction;
        best = direction_ == TurnDirection::kCcw ? 0 : n - 1;
        ord[best] = reversed ? lost_.ordinal : lost_.ordinal + sign(direction_);
      } else {
        ord[best] = lost_.ordinal;
      }
      known[best] = true;
    } else if (!seen_any_) {
      // The first board ever: the one nearest the centre is the start board.
      int best = 0;
      for (int i = 1; i < n; ++i) {
        if (std::abs(xs[i] - 0.5) < std::abs(xs[best] - 0.5)) best = i;
      }
      ord[best] = phase_ == SweepPhase::kSweep ? options_.start_board : 0;
      known[best] = true;
      start_in_view_ = steps_ == 1;
      start_ordinal_ = ord[best];
      ord_min_ = ord_max_ = ord[best];
    } else if (!frame_.empty()) {
      // Nothing matched within one step: the last frame's boards left by the trailing edge (or
      // dropped out) while others came in — a narrow lens sees one board at a time. Number them
      // from the last frame's board nearest the direction of travel: a board on the leading side
      // of where that board is now expected is the next one (boards are numbered
      // counter-clockwise: on a counter-clockwise turn the next board enters on the left).
      const bool ccw = direction_ == TurnDirection::kCcw;
      const Tracked* lead = &frame_.front();
      for (const Tracked& t : frame_) {
        if (ccw ? t.ordinal > lead->ordinal : t.ordinal < lead->ordinal) lead = &t;
      }
      const double lead_x = lead->x + shift;
      int best = 0;
      for (int i = 1; i < n; ++i) {
        if (std::abs(xs[i] - lead_x) < std::abs(xs[best] - lead_x)) best = i;
      }
      const bool leading_side = ccw ? xs[best] < lead_x : xs[best] > lead_x;
      ord[best] = leading_side ? lead->ordinal + sign(direction_) : lead->ordinal;
      known[best] = true;
    } else {
      // Cannot happen (an empty last frame always leaves lost_ active); keep the last board.
      ord[0] = board_;
      known[0] = true;
    }
  }
  // Boards not matched take their number from the nearest known one by rank.
  std::vector<int> known_ord = ord;
  for (int i = 0; i < n; ++i) {
    if (known[i]) continue;
    int nearest = -1;
    for (int j = 0; j < n; ++j) {
      if (known[j] && (nearest < 0 || std::abs(j - i) < std::abs(nearest - i))) nearest = j;
    }
    known_ord[i] = ord[nearest] + (i - nearest);
  }

  frame_.clear();
  int centre = 0;
  for (int i = 0; i < n; ++i) {
    frame_.push_back({xs[i], known_ord[i]});
    ord_min_ = std::min(ord_min_, known_ord[i]);
    ord_max_ = std::max(ord_max_, known_ord[i]);
    if (std::abs(xs[i] - 0.5) < std::abs(xs[centre] - 0.5)) centre = i;
  }
  board_ = known_ord[centre];
  seen_any_ = true;
  in_frame_ = true;
  recovery_ = false;
  lost_.active = false;
  recovery_steps_ = 0;
}

SweepDecision SweepController::decide(const SweepObservation& observation) {
  if (!std::isfinite(observation.turned_rad)) {
    throw InputError("sweep observation: turned_rad is not finite");
  }
  for (double x : observation.boards_x) {
    if (!(x >= 0.0 && x <= 1.0)) {
      throw InputError("sweep observation: board centre x " + std::to_string(x) +
                       " is outside [0, 1]");
    }
  }
  if (finished()) return final_;
  ++steps_;
  heading_rad_ += observation.turned_rad;
  if (turned_last_) {
    stalled_steps_ =
        std::abs(observation.turned_rad) < options_.min_step_rad ? stalled_steps_ + 1 : 0;
  }
  if (phase_ == SweepPhase::kSweep && !seen_any_ && observation.boards_x.empty()) {
    // Told the start board, but none is in view: find the boards as when nothing is known.
    phase_ = SweepPhase::kDiscoverFirst;
    count_ = 0;
  }

  track(observation.boards_x, observation.turned_rad / options_.camera_hfov_rad);
  if (in_frame_ && observation.view_kept) ++views_[board_];
  if (in_frame_ && leg_start_pending_) {
    leg_start_heading_rad_ = heading_rad_;
    leg_start_pending_ = false;
  }

  // Not before min_steps: a frame that holds a standing board and one lying on the floor can
  // satisfy the coverage measures within a few steps, from views of one corner of the area (the
  // wide lens's sweep ended after 7 steps and, through ROS, left the lower half of the image
  // 2.3 px uncertain).
  if (observation.coverage_sufficient && steps_ >= options_.min_steps) {
    return done("coverage sufficient after " + std::to_string(steps_) + " steps, pass " +
                std::to_string(pass_));
  }
  if (stalled_steps_ >= options_.max_stalled_steps) {
    return fail("the robot did not turn in " + std::to_string(stalled_steps_) +
                " steps in a row (each under " + fmt(options_.min_step_rad, 4) +
                " rad by the encoders): wheel blocked, duty below the deadband or encoders silent");
  }
  if (steps_ > options_.max_steps) {
    return fail("step budget exhausted (" + std::to_string(options_.max_steps) +
                " steps) without sufficient coverage");
  }
  if ((phase_ == SweepPhase::kDiscoverFirst || phase_ == SweepPhase::kDiscoverSecond) &&
      !leg_start_pending_ &&
      std::abs(heading_rad_ - leg_start_heading_rad_) > options_.full_turn_rad) {
    return fail(
        "turned a full revolution in the first pass without passing an extreme board: the boards "
        "stand all around the robot, or max_gap_rad (" +
        fmt(options_.max_gap_rad) + ") is larger than the empty arc outside the boards");
  }

  if (in_frame_) {
    if (phase_ == SweepPhase::kSweep) {
      for (const Tracked& t : frame_) {
        if (index(t.ordinal) < 0 || index(t.ordinal) >= count_) {
          return fail("saw a board beyond the extreme boards (board " +
                      std::to_string(index(t.ordinal)) + " of " + std::to_string(count_) +
                      "): board_count or start_board is wrong, or a board was counted twice");
        }
      }
    } else if (phase_ == SweepPhase::kDiscoverSecond && options_.board_count > 0 &&
               ord_max_ - ord_min_ + 1 > options_.board_count) {
      return fail("counted more boards than board_count (" + std::to_string(options_.board_count) +
                  ")");
    }
    return turn();
  }
  return whileLost();
}

SweepDecision SweepController::whileLost() {
  if (!seen_any_) {
    // Searching for a first board: one way round, at most a full revolution (§3.3 "in the worst
    // case, the robot will make no more than one revolution").
    if (std::abs(heading_rad_ - leg_start_heading_rad_) >= options_.full_turn_rad) {
      return fail("no board seen in a full turn (" + fmt(std::abs(heading_rad_)) + " rad, " +
                  std::to_string(steps_) + " frames)");
    }
    return turn();
  }
  recovery_ = true;
  ++recovery_steps_;
  const bool reversed = direction_ != lost_.direction;
  const double since = std::abs(heading_rad_ - recovery_start_heading_rad_);
  if (!reversed) {
    const bool left = lostBoardLeftFrame();
    if (phase_ == SweepPhase::kSweep) {
      const int extreme = direction_ == TurnDirection::kCcw ? count_ - 1 : 0;
      if (left && index(lost_.ordinal) == extreme) return endOfLeg();
    } else {
      // Discovery: nothing is known past the lost board, so turn on until a board comes in or the
      // turn is longer than any gap between neighbours — then it was an extreme board. When the
      // count is given, the second leg stops at the last board without this probe.
      const bool counted_all =
          phase_ == SweepPhase::kDiscoverSecond && options_.board_count > 0 &&
          ord_max_ - ord_min_ + 1 == options_.board_count &&
          lost_.ordinal == (direction_ == TurnDirection::kCcw ? ord_max_ : ord_min_);
      if ((left && counted_all) || since >= options_.max_gap_rad) return endOfLeg();
      if (recovery_steps_ > options_.max_recovery_steps) {
        return fail("no board for " + std::to_string(recovery_steps_) + " steps after " +
                    boardName(lost_.ordinal) + " and the encoders report only " + fmt(since) +
                    " rad: max_recovery_steps too small or the robot turns too little per step");
      }
      return turn();
    }
  }
  if (since > recovery_budget_rad_ || recovery_steps_ > options_.max_recovery_steps) {
    std::string target;
    if (reversed) {
      target = "turning " + std::string(name(direction_)) + " back to " + boardName(lost_.ordinal);
    } else if (!lostBoardLeftFrame()) {
      target = "waiting for it to come back in " + std::string(name(direction_));
    } else {
      target = "turning " + std::string(name(direction_)) + " toward " +
               boardName(lost_.ordinal + sign(direction_));
    }
    return fail("lost " + boardName(lost_.ordinal) + " and recovery (" + target +
                ") found no board in " + fmt(since) + " rad, " + std::to_string(recovery_steps_) +
                " steps (budget " + fmt(recovery_budget_rad_) + " rad, " +
                std::to_string(options_.max_recovery_steps) + " steps)");
  }
  return turn();
}

bool SweepController::finishDiscovery(std::string* failure) {
  const int counted = ord_max_ - ord_min_ + 1;
  offset_ = ord_min_;
  count_ = counted;
  if (options_.board_count > 0 && counted != options_.board_count) {
    *failure = "counted " + std::to_string(counted) + " boards in the first pass, board_count is " +
               std::to_string(options_.board_count);
    return false;
  }
  if (options_.start_board >= 0 && start_in_view_ &&
      index(start_ordinal_) != options_.start_board) {
    *failure = "the board in view at the start is board " + std::to_string(index(start_ordinal_)) +
               " of " + std::to_string(counted) + ", start_board is " +
               std::to_string(options_.start_board);
    return false;
  }
  return true;
}

SweepDecision SweepController::endOfLeg() {
  // Past the extreme board in the direction of travel (§3.2 recovery "turned so that it is not
  // already observing the extreme board"): a pass ends; reverse toward the same board.
  if (phase_ == SweepPhase::kDiscoverFirst) {
    phase_ = SweepPhase::kDiscoverSecond;
  } else {
    if (phase_ == SweepPhase::kDiscoverSecond) {
      phase_ = SweepPhase::kSweep;
      std::string failure;
      if (!finishDiscovery(&failure)) return fail(failure);
    }
    if (pass_ >= options_.max_passes) {
      return fail(std::to_string(pass_) + " passes over the " + std::to_string(count_) +
                  " boards (max_passes) without sufficient coverage");
    }
  }
  ++pass_;
  const double overshoot = std::abs(heading_rad_ - lost_.heading_rad);
  direction_ = opposite(direction_);
  recovery_start_heading_rad_ = heading_rad_;
  recovery_budget_rad_ = overshoot + options_.max_gap_rad;
  recovery_steps_ = 0;
  leg_start_pending_ = true;
  return turn();
}

}  // namespace camera
}  // namespace autocal
