// The sweep controller (paper 000 §3.2) against a scripted world: boards at known bearings around
// a robot that turns in steps, a pinhole camera with a horizontal field of view, and encoders that
// report the turn (optionally with a scale error). Decisions are checked against this geometry:
// the board the controller believes it views is the one nearest the image centre, reversals happen
// only past the extreme boards, and the counts found by the first pass are the world's.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "autocal/camera/sweep_controller.h"
#include "autocal/errors.h"

using namespace autocal::camera;

namespace {

constexpr double kDeg = M_PI / 180.0;

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// Boards around a robot that pivots in place; what a settled frame shows.
struct World {
  std::vector<double> bearings_rad;  ///< board centres, counter-clockwise (increasing)
  double half_width_rad = 6 * kDeg;  ///< a board is found only when it is wholly in the frame
  double hfov_rad = 90 * kDeg;
  double heading_rad = 0;
  double step_rad = 2 * kDeg;
  double encoder_scale = 1.0;    ///< reported turn = true turn · scale
  double encoder_scale_cw = 0;   ///< the scale of clockwise turns when not 0 (other wheel)
  std::set<int> dropout_frames;  ///< frames in which detection finds nothing
  int frame = 0;

  static World semicircle() {  // as the simulator's default world: 5 boards 40° apart
    World w;
    for (int i = -2; i <= 2; ++i) w.bearings_rad.push_back(i * 40 * kDeg);
    return w;
  }

  std::vector<int> visible() const {
    std::vector<int> v;
    for (int i = 0; i < static_cast<int>(bearings_rad.size()); ++i) {
      const double rel = wrap(bearings_rad[i] - heading_rad);
      if (std::abs(rel) + half_width_rad <= hfov_rad / 2) v.push_back(i);
    }
    return v;
  }
  double imageX(int board) const {
    const double rel = wrap(bearings_rad[board] - heading_rad);
    return 0.5 - std::tan(rel) / (2 * std::tan(hfov_rad / 2));  // left of the axis = small x
  }
  int centreBoard() const {
    int best = -1;
    for (int i : visible()) {
      if (best < 0 || std::abs(imageX(i) - 0.5) < std::abs(imageX(best) - 0.5)) best = i;
    }
    return best;
  }
  SweepObservation observe(double turned_true_rad) {
    SweepObservation o;
    const bool cw = turned_true_rad < 0 && encoder_scale_cw > 0;
    o.turned_rad = turned_true_rad * (cw ? encoder_scale_cw : encoder_scale);
    if (!dropout_frames.count(frame)) {
      for (int i : visible()) o.boards_x.push_back(imageX(i));
    }
    ++frame;
    return o;
  }
};

struct Reversal {
  double heading_rad;
  TurnDirection from;
};

struct Trace {
  SweepDecision last;
  std::vector<Reversal> reversals;
  std::set<int> centred;  ///< true boards seen nearest the centre
  int checked = 0;        ///< frames where the controller's board was compared
  int mismatches = 0;     ///< ... and differed from the truth
  int recovery_frames = 0;
  std::set<int> recovery_targets;
  int frames = 0;
  std::string first_mismatch;
};

/// Runs the controller on the world until it ends. `coverage(frames with a board)` scripts the
/// view collector's verdict.
Trace run(
    World& w, SweepController& c,
    const std::function<bool(int)>& coverage = [](int) { return false; }, int max_frames = 20000) {
  Trace t;
  double turned = 0;
  int board_frames = 0;
  bool have_last = false;
  TurnDirection last_dir = TurnDirection::kCw;
  while (t.frames < max_frames) {
    SweepObservation o = w.observe(turned);
    if (!o.boards_x.empty()) ++board_frames;
    o.view_kept = !o.boards_x.empty();
    o.coverage_sufficient = coverage(board_frames);
    const SweepDecision d = c.decide(o);
    ++t.frames;
    const int truth = w.centreBoard();
    if (!o.boards_x.empty()) t.centred.insert(truth);
    if (c.boardsKnown() && c.inFrame()) {
      ++t.checked;
      if (c.board() != truth) {
        if (t.mismatches == 0) {
          t.first_mismatch = "frame " + std::to_string(t.frames) + ": controller board " +
                             std::to_string(c.board()) + ", truth " + std::to_string(truth) + " (" +
                             c.describe() + ")";
        }
        ++t.mismatches;
      }
    }
    if (c.recovery()) {
      ++t.recovery_frames;
      if (c.recoveryTarget() >= 0) t.recovery_targets.insert(c.recoveryTarget());
    }
    if (!d.turn()) {
      t.last = d;
      return t;
    }
    if (have_last && d.direction != last_dir) t.reversals.push_back({w.heading_rad, last_dir});
    have_last = true;
    last_dir = d.direction;
    turned = sign(d.direction) * w.step_rad;
    w.heading_rad += turned;
  }
  t.last.reason = "test: no end within the frame limit";
  return t;
}

/// Heading at which board `i` leaves the frame turning in `from` (its edge reaches the border).
double exitHeading(const World& w, int i, TurnDirection from) {
  const double edge = w.hfov_rad / 2 - w.half_width_rad;
  return from == TurnDirection::kCw ? w.bearings_rad[i] - edge : w.bearings_rad[i] + edge;
}

/// Every reversal happens within two steps after the extreme board in its direction left.
void expectReversalsAtExtremes(const World& w, const std::vector<Reversal>& reversals) {
  const int last = static_cast<int>(w.bearings_rad.size()) - 1;
  for (const Reversal& r : reversals) {
    const int extreme = r.from == TurnDirection::kCw ? 0 : last;
    const double exit = exitHeading(w, extreme, r.from);
    const double past = sign(r.from) * (r.heading_rad - exit);
    EXPECT_GT(past, 0) << "reversed before board " << extreme << " left the frame";
    EXPECT_LE(past, 2 * w.step_rad + 1e-9) << "reversed late past board " << extreme;
  }
}

SweepOptions known(int count, int start) {
  SweepOptions o;
  o.board_count = count;
  o.start_board = start;
  return o;
}

// --- the paper's case: board count and start board given
// ------------------------------------------

TEST(SweepController, KnownLayoutVisitsEveryBoardOnEveryPassAndReversesAtTheExtremes) {
  World w = World::semicircle();
  SweepOptions o = known(5, 2);
  o.max_passes = 3;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  EXPECT_GT(t.checked, 200);
  EXPECT_EQ(t.centred, (std::set<int>{0, 1, 2, 3, 4}));
  // Start leg to board 0 (the paper starts clockwise), then three full passes; the third ends past
  // board 4 (CCW, odd pass count from board 0) with no coverage: failure, no further reversal.
  ASSERT_EQ(t.reversals.size(), 3u);
  EXPECT_EQ(t.reversals[0].from, TurnDirection::kCw);
  EXPECT_EQ(t.reversals[1].from, TurnDirection::kCcw);
  EXPECT_EQ(t.reversals[2].from, TurnDirection::kCw);
  expectReversalsAtExtremes(w, t.reversals);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("3 passes"), std::string::npos) << t.last.reason;
  EXPECT_EQ(c.pass(), 3);
  EXPECT_GT(w.heading_rad, exitHeading(w, 4, TurnDirection::kCcw));
  // Recovery only ever turned back to an extreme board.
  EXPECT_EQ(t.recovery_targets, (std::set<int>{0, 4}));
  // Views were counted for every board.
  for (int v : c.viewsPerBoard()) EXPECT_GT(v, 0);
}

TEST(SweepController, EndsWhenCoverageIsSufficient) {
  World w = World::semicircle();
  SweepController c(known(5, 2));
  const Trace t = run(w, c, [](int frames) { return frames >= 120; });
  EXPECT_EQ(t.last.action, SweepAction::kDone) << t.last.reason;
  EXPECT_NE(t.last.reason.find("coverage"), std::string::npos);
  EXPECT_TRUE(c.finished());
  // Stays ended: a later frame gets the same answer.
  EXPECT_EQ(c.decide(SweepObservation{}).action, SweepAction::kDone);
  EXPECT_LT(c.pass(), 3);
}

TEST(SweepController, CounterClockwiseStartGoesToTheLastBoardFirst) {
  World w = World::semicircle();
  SweepOptions o = known(5, 2);
  o.initial_direction = TurnDirection::kCcw;
  o.max_passes = 1;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  ASSERT_EQ(t.reversals.size(), 1u);
  EXPECT_EQ(t.reversals[0].from, TurnDirection::kCcw);
  expectReversalsAtExtremes(w, t.reversals);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_LT(w.heading_rad, exitHeading(w, 0, TurnDirection::kCw));
}

TEST(SweepController, RecoversAcrossAGapBetweenBoards) {
  World w;
  w.bearings_rad = {-60 * kDeg, 0, 110 * kDeg};  // 0 → 1 overlap; 1 → 2: 32° with no board
  SweepOptions o = known(3, 1);
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  EXPECT_EQ(t.centred, (std::set<int>{0, 1, 2}));
  // Recovery turned on toward board 2 (and back toward 1) through the gap, and back to the
  // extremes.
  EXPECT_EQ(t.recovery_targets, (std::set<int>{0, 1, 2}));
  ASSERT_EQ(t.reversals.size(), 2u);
  expectReversalsAtExtremes(w, t.reversals);
  EXPECT_NE(t.last.reason.find("2 passes"), std::string::npos) << t.last.reason;
}

TEST(SweepController, OneBoardIsBothExtremes) {
  World w;
  w.bearings_rad = {10 * kDeg};
  SweepOptions o = known(1, 0);
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  ASSERT_EQ(t.reversals.size(), 2u);
  expectReversalsAtExtremes(w, t.reversals);
}

TEST(SweepController, FailsWhenRecoveryExceedsItsBudget) {
  World w;
  w.bearings_rad = {0, 150 * kDeg};  // 72° with no board between them
  SweepOptions o = known(2, 0);
  o.initial_direction = TurnDirection::kCcw;
  o.max_gap_rad = 0.8;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("lost board 0"), std::string::npos) << t.last.reason;
  EXPECT_NE(t.last.reason.find("toward board 1"), std::string::npos) << t.last.reason;
  // It gave up once the budget was spent, not before, not much later.
  const double since_loss = w.heading_rad - exitHeading(w, 0, TurnDirection::kCcw);
  EXPECT_GT(since_loss, 0.8);
  EXPECT_LT(since_loss, 0.8 + 2 * w.step_rad);

  // The step budget alone: the encoders report a tenth of the turn.
  World w2 = w;
  w2.heading_rad = 0;
  w2.frame = 0;
  w2.encoder_scale = 0.1;
  SweepOptions o2 = o;
  o2.max_gap_rad = 1.2;
  o2.max_recovery_steps = 30;
  SweepController c2(o2);
  const Trace t2 = run(w2, c2);
  EXPECT_EQ(t2.last.action, SweepAction::kFailed);
  EXPECT_NE(t2.last.reason.find("31 steps"), std::string::npos) << t2.last.reason;
}

TEST(SweepController, DetectionDropOutIsNotALostBoard) {
  // Detection fails in single frames, also while the extreme boards are mid-frame.
  World w = World::semicircle();
  for (int f = 5; f < 2000; f += 23) w.dropout_frames.insert(f);
  SweepOptions o = known(5, 2);
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  ASSERT_EQ(t.reversals.size(), 2u);
  expectReversalsAtExtremes(w, t.reversals);
  EXPECT_NE(t.last.reason.find("2 passes"), std::string::npos) << t.last.reason;
}

TEST(SweepController, TracksWithEncoderScaleErrors) {
  for (double scale : {0.8, 1.25}) {
    World w = World::semicircle();
    w.encoder_scale = scale;
    SweepOptions o = known(5, 2);
    o.max_passes = 2;
    SweepController c(o);
    const Trace t = run(w, c);
    EXPECT_EQ(t.mismatches, 0) << "scale " << scale << ": " << t.first_mismatch;
    ASSERT_EQ(t.reversals.size(), 2u) << "scale " << scale;
    expectReversalsAtExtremes(w, t.reversals);
  }
}

TEST(SweepController, FirstPassWithEncoderScaleErrors) {
  // Turns each way are measured on a different wheel, 25 % apart: after the probe past an extreme
  // board the expected position of the lost board is off by a fifth of the image, and the board
  // that comes back is known by recovery's direction rule.
  for (double scale : {0.8, 1.25}) {
    World w = World::semicircle();
    w.encoder_scale = scale;
    w.encoder_scale_cw = 1.0 / scale;
    SweepOptions o;
    o.max_passes = 2;
    SweepController c(o);
    const Trace t = run(w, c);
    EXPECT_EQ(c.boardCount(), 5) << "scale " << scale;
    EXPECT_EQ(c.startBoard(), 2) << "scale " << scale;
    EXPECT_EQ(t.mismatches, 0) << "scale " << scale << ": " << t.first_mismatch;
    EXPECT_NE(t.last.reason.find("2 passes over the 5 boards"), std::string::npos) << t.last.reason;
  }
}

TEST(SweepController, FirstPassCrossesAGap) {
  World w;
  w.bearings_rad = {-60 * kDeg, 0, 110 * kDeg};  // 32° without a board between 1 and 2
  w.heading_rad = 5 * kDeg;
  SweepOptions o;
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(c.boardCount(), 3);
  EXPECT_EQ(c.startBoard(), 1);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  EXPECT_EQ(t.recovery_targets.count(2), 1u);
}

TEST(SweepController, NarrowLensHandsOverFromOneBoardToTheNextWithinAStep) {
  // A narrow lens (70°) sees one board at a time, and with large steps (6°) one board leaves by
  // the trailing edge in the same step as the next one comes in by the leading edge: no board is
  // matched across that step, and the newcomer is the next board, not the one that left.
  World w = World::semicircle();
  w.hfov_rad = 70 * kDeg;
  w.half_width_rad = 14 * kDeg;
  w.step_rad = 6 * kDeg;
  SweepOptions o;
  o.camera_hfov_rad = 92 * kDeg;  // camera_info's nominal lens, wider than the true one
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(c.boardCount(), 5);
  EXPECT_EQ(c.startBoard(), 2);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  EXPECT_NE(t.last.reason.find("2 passes over the 5 boards"), std::string::npos) << t.last.reason;
}

TEST(SweepController, WrongBoardCountIsReported) {
  World w = World::semicircle();
  SweepController c(known(4, 2));  // there are 5: board "4" shows up beyond the last
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("beyond the extreme boards"), std::string::npos) << t.last.reason;
}

TEST(SweepController, StallIsAFailure) {
  World w = World::semicircle();
  w.step_rad = 0;  // the wheel does not move
  SweepController c(known(5, 2));
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("did not turn"), std::string::npos) << t.last.reason;
  EXPECT_EQ(t.frames, 1 + SweepOptions().max_stalled_steps);
}

// --- the first pass: board count and start board found by the robot ----------------------------

TEST(SweepController, FirstPassFindsBoardCountAndStartBoard) {
  for (double start_deg : {0.0, 40.0, -75.0, 20.0}) {
    World w = World::semicircle();
    w.heading_rad = start_deg * kDeg;
    const int truth_start = w.centreBoard();
    SweepOptions o;
    o.max_passes = 3;
    SweepController c(o);
    EXPECT_FALSE(c.boardsKnown());
    EXPECT_EQ(c.board(), -1);
    const Trace t = run(w, c);
    EXPECT_EQ(c.boardCount(), 5) << "start " << start_deg;
    EXPECT_EQ(c.startBoard(), truth_start) << "start " << start_deg;
    EXPECT_EQ(t.mismatches, 0) << "start " << start_deg << ": " << t.first_mismatch;
    EXPECT_GT(t.checked, 100);
    // Discovery reverses max_gap_rad past each extreme; the passes after it right after the loss.
    ASSERT_EQ(t.reversals.size(), 3u) << "start " << start_deg;
    EXPECT_EQ(t.reversals[0].from, TurnDirection::kCw);
    for (int k = 0; k < 2; ++k) {
      const Reversal& r = t.reversals[k];
      const double past =
          sign(r.from) *
          (r.heading_rad - exitHeading(w, r.from == TurnDirection::kCw ? 0 : 4, r.from));
      EXPECT_NEAR(past, o.max_gap_rad, 2 * w.step_rad) << "start " << start_deg;
    }
    expectReversalsAtExtremes(w, {t.reversals[2]});
    EXPECT_EQ(t.last.action, SweepAction::kFailed);
    EXPECT_NE(t.last.reason.find("3 passes over the 5 boards"), std::string::npos) << t.last.reason;
  }
}

TEST(SweepController, FirstPassWithAGapAndAGivenCount) {
  World w;
  w.bearings_rad = {-60 * kDeg, 0, 110 * kDeg};
  w.heading_rad = 110 * kDeg;  // start at board 2, beyond the gap
  SweepOptions o;
  o.board_count = 3;  // start unknown: the first pass runs, and stops at board 2 without probing
  o.max_passes = 2;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(c.boardCount(), 3);
  EXPECT_EQ(c.startBoard(), 2);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  ASSERT_EQ(t.reversals.size(), 2u);
  expectReversalsAtExtremes(w, {t.reversals[1]});
  // The second leg ended right after board 2 left (count given), not a gap probe later.
  const Reversal& r = t.reversals[1];
  EXPECT_EQ(r.from, TurnDirection::kCcw);
  EXPECT_LE(r.heading_rad - exitHeading(w, 2, TurnDirection::kCcw), 2 * w.step_rad);
}

TEST(SweepController, FirstPassCountDisagreeingWithTheGivenCountFails) {
  World w = World::semicircle();
  SweepOptions o;
  o.board_count = 4;
  SweepController c(o);
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("counted more boards"), std::string::npos) << t.last.reason;
}

TEST(SweepController, StartFacingAwayTurnsUntilTheBoardsComeIntoView) {
  World w = World::semicircle();
  w.heading_rad = 180 * kDeg;
  SweepController c(known(5, 2));  // told a start board, but none is in view: discover
  const Trace t = run(w, c);
  EXPECT_EQ(c.boardCount(), 5);
  EXPECT_EQ(c.startBoard(), -1);
  EXPECT_EQ(t.mismatches, 0) << t.first_mismatch;
  EXPECT_EQ(t.centred, (std::set<int>{0, 1, 2, 3, 4}));
}

TEST(SweepController, NoBoardInAFullTurnFails) {
  World w;  // no boards
  SweepController c(SweepOptions{});
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("no board seen in a full turn"), std::string::npos) << t.last.reason;
  const double full = SweepOptions().full_turn_rad;
  EXPECT_GE(full, 2 * M_PI);
  EXPECT_GE(std::abs(w.heading_rad) + w.step_rad, full);
  EXPECT_LT(std::abs(w.heading_rad), full + w.step_rad);
}

TEST(SweepController, BoardsAllAroundFailTheFirstPass) {
  World w;
  for (int i = 0; i < 9; ++i) w.bearings_rad.push_back((-180 + 40 * i) * kDeg);
  SweepController c(SweepOptions{});
  const Trace t = run(w, c);
  EXPECT_EQ(t.last.action, SweepAction::kFailed);
  EXPECT_NE(t.last.reason.find("full revolution"), std::string::npos) << t.last.reason;
}

// --- inputs and options -----------------------------------------------------------------------

TEST(SweepController, RejectsBadObservations) {
  SweepController c(known(5, 2));
  SweepObservation o;
  o.turned_rad = NAN;
  EXPECT_THROW(c.decide(o), autocal::InputError);
  o.turned_rad = 0;
  o.boards_x = {1.2};
  EXPECT_THROW(c.decide(o), autocal::InputError);
  o.boards_x = {0.5};
  EXPECT_TRUE(c.decide(o).turn());
}

TEST(SweepOptions, ValidateNamesTheBadKey) {
  auto expectBad = [](const std::function<void(SweepOptions&)>& edit, const std::string& key) {
    SweepOptions o;
    edit(o);
    try {
      o.validate();
      ADD_FAILURE() << key << " accepted";
    } catch (const autocal::ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(key + ":", 0), 0u) << e.what();
    }
  };
  SweepOptions().validate();
  expectBad([](SweepOptions& o) { o.board_count = -1; }, "board_count");
  expectBad([](SweepOptions& o) { o.board_count = 3, o.start_board = 3; }, "start_board");
  expectBad([](SweepOptions& o) { o.max_passes = 0; }, "max_passes");
  expectBad([](SweepOptions& o) { o.camera_hfov_rad = 0; }, "camera_hfov_rad");
  expectBad([](SweepOptions& o) { o.max_gap_rad = 7; }, "max_gap_rad");
  expectBad([](SweepOptions& o) { o.track_gate = NAN; }, "track_gate");
  expectBad([](SweepOptions& o) { o.trailing_margin = 0.6; }, "trailing_margin");
  expectBad([](SweepOptions& o) { o.step_duration_s = 0; }, "step_duration_s");
  expectBad([](SweepOptions& o) { o.max_settle_s = 0.1; }, "max_settle_s");
  EXPECT_THROW(SweepController{[] {
                 SweepOptions o;
                 o.max_steps = 0;
                 return o;
               }()},
               autocal::ConfigError);
}

}  // namespace
