// Each wheel's duty → steady speed line from the wheel stage's drives (beyond paper 000: the
// deadband). A drive's steady rate per wheel is the least-squares slope of its encoder ticks after
// the motors' lag; the line through the drives' (duty, rate) points gives the duty at which the
// wheel starts to turn. A gear motor's speed per duty differs a few per cent between forward and
// backward, its deadband hardly: once one direction's drives span two duties, each direction gets
// its own slope through one shared offset (before, one line through every drive, which such a
// motor bends). Shared by the live wheel stage (WheelRun) and its replay (WheelReplay), so
// that a recording is fitted exactly as the robot fitted it.
#pragma once

#include <array>
#include <vector>

#include "autocal/sensors.h"

namespace autocal {
namespace wheels {

/// One wheel's duty → steady speed line [rad/s per duty].
struct MotorFit {
  bool valid = false;
  double slope = 0;           ///< forward [rad/s]
  double backward_slope = 0;  ///< [rad/s]; the forward slope until the directions are told apart
  double offset = 0;          ///< duty at which the wheel starts to turn [1]
  int points = 0;
  /// Each direction has its own slope (some direction's drives span two duties).
  bool per_direction = false;
};

struct MotorFitOptions {
  /// The start of a drive that the fit skips (the wheels' lag) [s].
  double motor_settle_s = 0.3;
  /// Only drives whose steady part lasts this long enter the fit [s].
  double min_fit_window_s = 0.8;
  /// Drives whose rates make the fit; later drives leave it as it is.
  int fit_drives = 8;
  /// A drive off the other drives' line by more than this share is left out [1].
  double max_fit_residual = 0.015;
  /// A steered drive whose mean duty differs between the two halves of the steady part by more
  /// than this is left out [duty]: its rate follows the duties late (the motors' lag), and a duty
  /// still settling is not the one its rate answers.
  double max_duty_trend = 0.002;
};

/// One drive as the encoders saw it: commanded duties (their magnitudes are used), when the
/// command started and stopped, and the (stamp [s], left ticks, right ticks) readings meanwhile.
struct DriveRecord {
  WheelDuties duties;
  bool backward = false;  ///< a drive back
  double start_s = 0, end_s = 0;
  std::vector<std::array<double, 3>> samples;
  /// A steered drive's commands, (stamp [s], left duty, right duty), in stamp order: from its
  /// stamp on, each replaces `duties` (magnitudes used). Empty: `duties` throughout.
  std::vector<std::array<double, 3>> commands;
};

/// The duty magnitudes a drive commanded on average over [t0_s, t1_s], weighted over time as the
/// fit's least-squares rate weighs the speed (the middle most); `duties` when the drive holds no
/// commands or the window is empty.
WheelDuties meanDuties(const DriveRecord& drive, double t0_s, double t1_s);

/// The wheels a fit has no line for, for a reason: "left and right wheels", "left wheel", "right
/// wheel" ("" when both have one).
const char* wheelsWithoutLine(const MotorFit& left, const MotorFit& right);

class MotorFitter {
 public:
  /// One drive's point on one wheel's line: |duty|, steady rate [rad/s], the fit's weight.
  struct Point {
    double duty = 0, rate = 0, weight = 0;
    bool backward = false;
  };

  explicit MotorFitter(const MotorFitOptions& options) : options_(options) {}

  /// Adds a drive's point to both wheels' lines (unless the fit is frozen, the drive too short or
  /// too sparsely sampled) and refits. `ticks_per_revolution` > 0.
  void addDrive(const DriveRecord& drive, int ticks_per_revolution);
  const MotorFit& left() const { return left_; }
  const MotorFit& right() const { return right_; }
  /// Drives whose points are in the fit (after outliers were dropped).
  int points() const { return static_cast<int>(points_left_.size()); }
  /// fit_drives points are in the fit: it no longer changes.
  bool frozen() const { return points() >= options_.fit_drives; }

 private:
  MotorFitOptions options_;
  std::vector<Point> points_left_, points_right_;
  MotorFit left_, right_;
};

}  // namespace wheels
}  // namespace autocal
