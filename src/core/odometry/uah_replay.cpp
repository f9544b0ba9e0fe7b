// The UAH calibration recomputed from a recording (paper 002 §2); see uah_replay.h.
#include "autocal/odometry/uah_replay.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace odometry {

namespace {

/// A forward run whose right duty over its fast window is this much above its slow one went at
/// two speeds (one speed: the same within a sagging battery's per cent or two).
constexpr double kTwoSpeedsDutyRatio = 1.25;

struct Sample {
  double stamp_s;
  double left, right;  // unwrapped ticks
};

bool isTurn(UahExperiment e) {
  return e == UahExperiment::kPivotLeftStopped || e == UahExperiment::kPivotRightStopped ||
         e == UahExperiment::kSpin;
}

std::string at(double t_s) { return formatNumber(t_s, 5) + " s"; }

UahExperiment experimentFromPhase(const std::string& phase) {
  for (UahExperiment e : {UahExperiment::kPivotLeftStopped, UahExperiment::kPivotRightStopped,
                          UahExperiment::kSpin, UahExperiment::kFace, UahExperiment::kStraight}) {
    if (phase == std::string("odometry/") + name(e)) return e;
  }
  return UahExperiment::kWait;
}

/// Whether the commands of a motion are what the live run commands in `e`. A driven wheel's duty
/// may fall to zero for a while: its rate control slows it (a robot whose readings come late
/// swings about its rate).
bool commandsFit(UahExperiment e, double left, double right) {
  switch (e) {
    case UahExperiment::kPivotLeftStopped:
      return left == 0 && right >= 0;
    case UahExperiment::kPivotRightStopped:
      return left >= 0 && right == 0;
    case UahExperiment::kSpin:
      return left <= 0 && right >= 0;
    case UahExperiment::kFace:  // a pivot on either stopped wheel
      return (left == 0 && right >= 0) || (left >= 0 && right == 0);
    case UahExperiment::kStraight:  // the heading hold may take the left duty to 0
      return left * right >= 0;
    default:
      return false;
  }
}

/// §2.1's N_t from the nominal parameters, as UahRun's detection window.
RoundDetectionOptions detectionFor(const UahRunOptions& o, UahExperiment e) {
  RoundDetectionOptions d = o.detection;
  const DiffDriveParams& n = o.nominal;
  if (e == UahExperiment::kPivotLeftStopped) {
    d.expected_pulses_per_round = 2 * M_PI * n.wheelbase_m / n.right_m_per_pulse;
  } else if (e == UahExperiment::kPivotRightStopped) {
    d.expected_pulses_per_round = 2 * M_PI * n.wheelbase_m / n.left_m_per_pulse;
  } else {
    d.expected_pulses_per_round =
        2 * M_PI * n.wheelbase_m / (n.left_m_per_pulse + n.right_m_per_pulse);
  }
  return d;
}

/// The turn's pulse axis (UahRun::turnPulses): the moving wheel on a pivot; on the spin
/// (N_R − N_L/Ed)·Ed/(1 + Ed), a round of which is 2π·b/(c_L + c_R) pulses.
double turnPulses(UahExperiment e, const Sample& s, const Sample& start, double Ed) {
  const double dl = s.left - start.left, dr = s.right - start.right;
  if (e == UahExperiment::kPivotLeftStopped) return dr;
  if (e == UahExperiment::kPivotRightStopped) return dl;
  return (dr - dl / Ed) * Ed / (1 + Ed);
}

}  // namespace

void UahReplayOptions::validate() const {
  run.validate();
  for (double l : straight_lengths_m) {
    checkConfig(std::isfinite(l) && l > 0, "straight_length_m", "must be > 0 [m]");
  }
}

UahReplayResult replayUah(UahRecording rec, const UahReplayOptions& options) {
  options.validate();
  const UahRunOptions& o = options.run;
  UahReplayResult out;
  if (rec.encoders.empty()) throw InputError("the recording has no encoder readings");
  if (rec.ranges.empty()) throw InputError("the recording has no range readings");
  if (rec.commands.empty()) throw InputError("the recording has no wheel commands");
  if (rec.statuses.empty()) throw InputError("the recording has no calibration status");
  auto byStamp = [](const auto& a, const auto& b) { return a.stamp_s < b.stamp_s; };
  std::stable_sort(rec.ranges.begin(), rec.ranges.end(), byStamp);
  std::stable_sort(rec.commands.begin(), rec.commands.end(), byStamp);
  std::stable_sort(rec.statuses.begin(), rec.statuses.end(), byStamp);
  std::stable_sort(rec.lengths.begin(), rec.lengths.end(), byStamp);

  // The encoders as UahRun reads them: in arrival order, stamps going back dropped, 32-bit counts
  // unwrapped, a reset or jump refused, the two wheels' messages of one stamp merged.
  std::vector<Sample> enc;
  {
    std::int32_t raw_l = rec.encoders.front().left, raw_r = rec.encoders.front().right;
    double l = 0, r = 0, last_s = rec.encoders.front().stamp_s;
    enc.push_back({last_s, 0, 0});
    const auto diff = [](std::int32_t now, std::int32_t before) {
      return static_cast<double>(static_cast<std::int32_t>(static_cast<std::uint32_t>(now) -
                                                           static_cast<std::uint32_t>(before)));
    };
    for (const auto& e : rec.encoders) {
      if (e.stamp_s < last_s) continue;
      const double dl = diff(e.left, raw_l), dr = diff(e.right, raw_r);
      const double allowed =
          o.max_encoder_rate_pulses_per_s * std::max(e.stamp_s - last_s, o.encoder_jump_window_s) +
          5;
      if (std::abs(dl) > allowed || std::abs(dr) > allowed) {
        throw InputError("encoder jump at " + at(e.stamp_s) + ": left " + formatNumber(dl, 8) +
                         ", right " + formatNumber(dr, 8) + " ticks in " +
                         formatNumber(e.stamp_s - last_s, 3) +
                         " s (an encoder reset or a glitch in the recording); the pulse counts "
                         "cannot be trusted");
      }
      raw_l = e.left, raw_r = e.right;
      l += dl, r += dr;
      if (e.stamp_s == enc.back().stamp_s) {
        enc.back() = {e.stamp_s, l, r};
      } else {
        enc.push_back({e.stamp_s, l, r});
      }
      last_s = e.stamp_s;
    }
  }
  out.recording_s =
      std::max({enc.back().stamp_s, rec.ranges.back().stamp_s, rec.commands.back().stamp_s}) -
      std::min({enc.front().stamp_s, rec.ranges.front().stamp_s, rec.commands.front().stamp_s});

  // The recorded run's own end.
  out.recorded_outcome = "unfinished";
  for (const auto& s : rec.statuses) {
    if (s.state == 2) out.recorded_outcome = "done";
    if (s.state == 3) out.recorded_outcome = "failed: " + s.failure_reason;
  }

  // Motions: stretches of commands not both zero. The live run starts a motion settle_s after the
  // last one stopped at the earliest: zeros for less than 3/4 of that are a motion's rate control
  // taking both duties to zero for a moment (a spin on a robot whose readings come 50 ms late:
  // 0.06-0.22 s), not a stop.
  struct Span {
    size_t first, last;  // command indices
  };
  std::vector<Span> spans;
  for (size_t i = 0; i < rec.commands.size(); ++i) {
    const bool moving = rec.commands[i].left != 0 || rec.commands[i].right != 0;
    if (!moving) continue;
    if (!spans.empty() && (spans.back().last + 1 == i ||
                           rec.commands[i].stamp_s - rec.commands[spans.back().last + 1].stamp_s <
                               0.75 * o.settle_s)) {
      spans.back().last = i;
    } else {
      spans.push_back({i, i});
    }
  }
  if (spans.empty()) throw InputError("the recorded wheel commands never move the robot");

  // The encoders' settling after a stop (UahRun::settled): settle_s at least, then the encoders
  // still for still_s, or kMaxSettleS at most.
  auto settledAt = [&](double stop_s) {
    double last_change_s = stop_s;
    for (size_t i = 1; i < enc.size(); ++i) {
      const Sample& s = enc[i];
      if (s.stamp_s <= stop_s) continue;
      if (s.left != enc[i - 1].left || s.right != enc[i - 1].right) last_change_s = s.stamp_s;
      if (s.stamp_s >= stop_s + kMaxSettleS) return stop_s + kMaxSettleS;
      if (s.stamp_s >= stop_s + o.settle_s && s.stamp_s - last_change_s >= o.still_s)
        return s.stamp_s;
    }
    return std::min(stop_s + kMaxSettleS, enc.back().stamp_s);
  };

  // The odometry stage's first experiment. A recording of the whole run (calibrate.launch
  // odometry:=true) holds the camera and wheel stages' motions before it, on the same wheels_cmd:
  // motions that ended before it are theirs, not the UAH run's.
  double first_experiment_s = std::numeric_limits<double>::infinity();
  for (const auto& s : rec.statuses) {
    if (experimentFromPhase(s.phase) != UahExperiment::kWait) {
      first_experiment_s = std::min(first_experiment_s, s.stamp_s);
    }
  }
  if (!std::isfinite(first_experiment_s)) {
    throw InputError(
        "no odometry/<experiment> status was recorded: is this a recording of "
        "odometry_calibration_node's UAH run?");
  }

  // Each motion's experiment: the recorded status phase most seen while it moved (the node
  // publishes its status on every change of experiment, right after the command).
  int straight_index = 0;
  std::vector<double> right_ppr_left_stopped, left_ppr_right_stopped;
  double Ed = 1.0, spin_ppr = 0;
  std::vector<std::pair<UahReplayMotion, Sample>> straights;  // and their encoder start
  std::vector<std::vector<Sample>> straight_histories;
  for (size_t k = 0; k < spans.size(); ++k) {
    const Span& span = spans[k];
    UahReplayMotion m;
    m.start_s = rec.commands[span.first].stamp_s;
    m.stop_s = span.last + 1 < rec.commands.size() ? rec.commands[span.last + 1].stamp_s
                                                   : rec.commands[span.last].stamp_s;
    std::map<UahExperiment, int> votes;
    for (const auto& s : rec.statuses) {
      if (s.stamp_s < m.start_s || s.stamp_s > m.stop_s) continue;
      const UahExperiment e = experimentFromPhase(s.phase);
      if (e != UahExperiment::kWait) ++votes[e];
      if (isTurn(e)) m.recorded_round = std::max(m.recorded_round, static_cast<int>(s.round));
    }
    if (votes.empty()) {
      // A short motion between two status messages: the one before it.
      for (const auto& s : rec.statuses) {
        if (s.stamp_s > m.start_s) break;
        const UahExperiment e = experimentFromPhase(s.phase);
        if (e != UahExperiment::kWait) votes = {{e, 1}};
      }
    }
    if (votes.empty() && m.stop_s < first_experiment_s) {
      ++out.earlier_stage_motions;
      continue;
    }
    if (votes.empty()) {
      throw InputError("the robot moved at " + at(m.start_s) +
                       " but no odometry/<experiment> status was recorded by then: is this a "
                       "recording of odometry_calibration_node's UAH run?");
    }
    m.experiment = std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                     return a.second < b.second;
                   })->first;
    for (size_t i = span.first; i <= span.last; ++i) {
      const auto& c = rec.commands[i];
      if (!commandsFit(m.experiment, c.left, c.right)) {
        throw InputError("the motion at " + at(m.start_s) + " is recorded as " +
                         name(m.experiment) + " but its commands (left " + formatNumber(c.left, 3) +
                         ", right " + formatNumber(c.right, 3) + " at " + at(c.stamp_s) +
                         ") drive something else: the recording does not hang together");
      }
    }
    // The live run starts the next motion as soon as this one has settled: its data end there.
    m.end_s = settledAt(m.stop_s);
    if (k + 1 < spans.size()) m.end_s = std::min(m.end_s, rec.commands[spans[k + 1].first].stamp_s);
    // The motion's data start where the live run started it: at the update that sent its first
    // command, after that cycle's readings (UahRun::startTurn, startStraight). The robot stood
    // still before.
    const double window_start_s = m.start_s;

    std::vector<Sample> history;
    size_t i0 = 0;
    while (i0 + 1 < enc.size() && enc[i0 + 1].stamp_s <= window_start_s) ++i0;
    history.push_back(enc[i0]);
    for (size_t i = i0 + 1; i < enc.size() && enc[i].stamp_s <= m.end_s; ++i) {
      history.push_back(enc[i]);
    }
    if (history.size() < 3 || history.back().stamp_s < m.stop_s) {
      throw InputError(std::string(name(m.experiment)) + " at " + at(m.start_s) +
                       ": the recording has no encoder readings over the motion (a silent "
                       "encoder, or a recording cut short)");
    }
    const Sample start = history.front();

    if (m.experiment == UahExperiment::kFace) {
      // The turn back to the starting heading measures nothing.
      out.motions.push_back(m);
      continue;
    }
    if (m.experiment == UahExperiment::kStraight) {
      m.straight_run = ++straight_index;
      out.motions.push_back(m);
      straights.push_back({m, start});
      straight_histories.push_back(history);
      continue;
    }
    if (m.experiment == UahExperiment::kSpin) {
      try {
        Ed = estimateEd(right_ppr_left_stopped, left_ppr_right_stopped).Ed;
      } catch (const InputError&) {
        throw InputError("the spin at " + at(m.start_s) +
                         " comes before pivots on both stopped wheels were recorded");
      }
    }

    // §2.1: the range readings of the turn on its pulse axis, interpolated between encoder
    // readings; the whole turn's autocorrelation gives the pulses per round.
    const std::string what = std::string(name(m.experiment)) + " at " + at(m.start_s) + ": ";
    UahTurn turn;
    turn.experiment = m.experiment;
    turn.pulses_turned = turnPulses(m.experiment, history.back(), start, Ed);
    std::vector<RangeSample> samples;
    double n_valid = 0, sum = 0, sum2 = 0;
    size_t j = 0;
    for (const auto& r : rec.ranges) {
      // A reading at the very start belongs to the motion before (the live run reads the sensors
      // before it starts a motion).
      if (r.stamp_s <= window_start_s || r.stamp_s > m.end_s) continue;
      ++turn.range_readings;
      const bool valid = std::isfinite(r.range_m) && r.range_m >= o.detection.min_range_m &&
                         r.range_m <= o.detection.max_range_m;
      if (!valid) {
        ++turn.invalid_readings;
      } else {
        n_valid += 1, sum += r.range_m, sum2 += r.range_m * r.range_m;
      }
      if (r.stamp_s < history.front().stamp_s || r.stamp_s > history.back().stamp_s) continue;
      while (j + 1 < history.size() && history[j + 1].stamp_s < r.stamp_s) ++j;
      if (j + 1 >= history.size()) break;
      const Sample& a = history[j];
      const Sample& b = history[j + 1];
      const double span_s = b.stamp_s - a.stamp_s;
      const double f = span_s > 0 ? (r.stamp_s - a.stamp_s) / span_s : 0.0;
      const double pa = turnPulses(m.experiment, a, start, Ed);
      const double pb = turnPulses(m.experiment, b, start, Ed);
      samples.push_back({pa + f * (pb - pa), r.range_m});
    }
    if (turn.range_readings == 0) {
      throw InputError(what + "the recording has no range readings while the robot turned");
    }
    const double invalid = static_cast<double>(turn.invalid_readings) / turn.range_readings;
    if (invalid > o.max_invalid_range_fraction) {
      throw CalibrationError(what + formatNumber(100 * invalid, 3) +
                             " % of the range readings were dropouts or out of range (limit " +
                             formatNumber(100 * o.max_invalid_range_fraction, 3) + " %)");
    }
    const RoundDetectionOptions det = detectionFor(o, m.experiment);
    try {
      turn.detection = detectWholeRound(samples, det);
    } catch (const CalibrationError& e) {
      const double spread =
          n_valid >= 2 ? std::sqrt(std::max(0.0, sum2 / n_valid - std::pow(sum / n_valid, 2))) : 0;
      if (spread < o.min_range_spread_m) {
        throw CalibrationError(what + "the range barely changes as the robot turns (spread " +
                               formatNumber(1000 * spread, 3) +
                               " mm): a circular, symmetric or featureless scene");
      }
      throw CalibrationError(what + e.what());
    }
    // As the live run: a scene that decorrelates slowly does not locate the round (§3.1).
    {
      double first = 0;
      const std::vector<double> x = resampleOnPulses(samples, det, &first);
      const std::vector<double> ac =
          normalizedAutocorrelation(x, static_cast<int>(det.expected_pulses_per_round / 2));
      turn.decorrelation_fraction = 0.5;
      for (int lag = 1; lag < static_cast<int>(ac.size()); ++lag) {
        if (std::isfinite(ac[lag]) && ac[lag] < 0.3) {
          turn.decorrelation_fraction = lag / det.expected_pulses_per_round;
          break;
        }
      }
    }
    if (turn.decorrelation_fraction > o.max_decorrelation_fraction) {
      throw CalibrationError(what + "the range changes only slowly as the robot turns (it takes " +
                             formatNumber(100 * turn.decorrelation_fraction, 3) +
                             " % of a round to decorrelate): a circular, symmetric or featureless "
                             "scene, the round cannot be located precisely (paper 002 §3.1)");
    }
    if (turn.detection.rounds_used < std::min(o.rounds, 2)) {
      throw CalibrationError(what + "only " + std::to_string(turn.detection.rounds_used) +
                             " round peaks agreed in the autocorrelation");
    }
    const double ppr = turn.detection.pulses_per_round;
    if (m.experiment == UahExperiment::kPivotLeftStopped) right_ppr_left_stopped.push_back(ppr);
    if (m.experiment == UahExperiment::kPivotRightStopped) left_ppr_right_stopped.push_back(ppr);
    if (m.experiment == UahExperiment::kSpin) spin_ppr = ppr;
    out.turns.push_back(turn);
    out.motions.push_back(m);
  }
  if (right_ppr_left_stopped.empty() || left_ppr_right_stopped.empty()) {
    throw InputError("the recording holds no pivot on the stopped " +
                     std::string(right_ppr_left_stopped.empty() ? "left" : "right") + " wheel");
  }
  if (spin_ppr <= 0) throw InputError("the recording holds no spin in place");
  if (straights.empty()) throw InputError("the recording holds no straight run");

  // §2.3: the straight runs. The heading needs c_L/c_R (Ed) and b in the same units (UahRun's
  // headingParams); a centred mean over 5 readings takes out most of the ticks' quantisation.
  DiffDriveParams heading = o.nominal;
  heading.left_m_per_pulse = heading.right_m_per_pulse / Ed;
  heading.wheelbase_m =
      spin_ppr * (heading.left_m_per_pulse + heading.right_m_per_pulse) / (2 * M_PI);
  const size_t n_runs = straights.size();
  const auto& given = options.straight_lengths_m;
  if (!given.empty() && given.size() != 1 && given.size() != n_runs) {
    throw InputError("the recording holds " + std::to_string(n_runs) + " straight runs but " +
                     std::to_string(given.size()) +
                     " lengths were given (give one for every run, or one per run)");
  }
  out.lengths_source = given.empty() ? "recorded" : "given";
  for (size_t k = 0; k < n_runs; ++k) {
    const UahReplayMotion& m = straights[k].first;
    const Sample& start = straights[k].second;
    const std::vector<Sample>& history = straight_histories[k];
    double length_m = NAN;
    if (!given.empty()) {
      length_m = given.size() == 1 ? given[0] : given[k];
    } else {
      const double next_start_s = k + 1 < n_runs ? straights[k + 1].first.start_s : 1e300;
      for (const auto& l : rec.lengths) {
        if (l.stamp_s >= m.stop_s && l.stamp_s <= next_start_s) {
          length_m = l.length_m;
          break;
        }
      }
      if (!std::isfinite(length_m)) {
        throw InputError("straight run " + std::to_string(k + 1) + " (at " + at(m.start_s) +
                         ") has no length recorded on ~straight_length: give the runs' true "
                         "lengths with --straight-length-m");
      }
    }
    std::vector<std::pair<double, double>> cumulative;
    const int n = static_cast<int>(history.size()), half = 2;
    for (int i = 0; i < n; ++i) {
      const int lo = std::max(0, i - half), hi = std::min(n - 1, i + half);
      double l = 0, r = 0;
      for (int q = lo; q <= hi; ++q) l += history[q].left, r += history[q].right;
      cumulative.push_back({l / (hi - lo + 1) - start.left, r / (hi - lo + 1) - start.right});
    }
    StraightRun run;
    run.length_m = length_m;
    run.right_pulses = std::abs(history.back().right - start.right);
    run.max_heading_deviation_rad = maxHeadingDeviationRad(cumulative, heading);
    run.shortening = pathShortening(cumulative, heading);
    // The duties commanded over the run's windows by the reference wheel's pulses, as the live
    // run keeps them (straightRunFit): at one speed its second half; a forward run that went
    // faster over its second half, its slow and fast parts.
    const StraightRunWindows windows;
    // Shares of the pulses the live run aimed at (it stops there and coasts on), as it took them.
    const double target_pulses = o.straight_length_m / o.nominal.right_m_per_pulse;
    auto stampAt = [&](double share) {
      for (const Sample& s : history)
        if (std::abs(s.right - start.right) >= share * target_pulses) return s.stamp_s;
      return m.stop_s;
    };
    auto meanDuties = [&](double from_s, double to_s, double& left, double& right) {
      double l = 0, r = 0;
      int count = 0;
      for (const auto& c : rec.commands) {
        if (c.stamp_s < from_s || c.stamp_s >= to_s) continue;
        l += std::abs(c.left), r += std::abs(c.right), ++count;
        run.forward = c.right > 0;
      }
      if (count > 0) left = l / count, right = r / count;
    };
    // At two speeds the duties were held from the window's start, the pulses' slope taken from
    // hold_settle_s later, as the live run takes both.
    const double slow_from_s = stampAt(windows.slow_begin) + windows.hold_settle_s;
    const double slow_to_s = stampAt(windows.slow_end);
    const double fast_from_s = stampAt(windows.fast_begin) + windows.hold_settle_s;
    double slow_left = 0, slow_right = 0, fast_left = 0, fast_right = 0;
    meanDuties(slow_from_s, slow_to_s, slow_left, slow_right);
    meanDuties(fast_from_s, m.stop_s, fast_left, fast_right);
    // The left wheel's lag over a window, from the encoder readings in it (PulseLine).
    auto lagOver = [&](double from_s, double to_s) {
      PulseLine line;
      for (const Sample& s : history) {
        if (s.stamp_s >= from_s && s.stamp_s < to_s)
          line.add(std::abs(s.left - start.left), std::abs(s.right - start.right));
      }
      return line.leftLag(Ed);
    };
    if (run.forward && slow_right > 0 && fast_right > kTwoSpeedsDutyRatio * slow_right) {
      run.mean_left_duty = slow_left, run.mean_right_duty = slow_right;
      run.fast_left_duty = fast_left, run.fast_right_duty = fast_right;
      run.slow_left_lag = lagOver(slow_from_s, slow_to_s);
      run.fast_left_lag = lagOver(fast_from_s, m.stop_s);
    } else {
      const double from_s = stampAt(windows.begin);
      meanDuties(from_s, m.stop_s, run.mean_left_duty, run.mean_right_duty);
      run.slow_left_lag = lagOver(from_s, m.stop_s);
    }
    const double odometry_m = run.right_pulses * o.nominal.right_m_per_pulse;
    if (std::abs(length_m / odometry_m - 1) > o.max_length_mismatch) {
      throw CalibrationError("straight run " + std::to_string(k + 1) + " (at " + at(m.start_s) +
                             "): the length " + formatNumber(length_m, 4) + " m is far from the " +
                             formatNumber(odometry_m, 4) +
                             " m the nominal right wheel counted (a run cut short, a slipping "
                             "wheel or a wrong length)");
    }
    out.straight_runs.push_back(run);
  }
  out.result = computeUah(o.nominal, right_ppr_left_stopped, left_ppr_right_stopped,
                          out.straight_runs, spin_ppr, o.straight);
  checkOdometryCalibration(out.result.toOdometryCalibration(""));
  return out;
}

}  // namespace odometry
}  // namespace autocal
