// The run's paths: the one the robot believes (its encoders dead-reckoned) and, in the
// simulator, the true one in the same frame. ROS-free.
#pragma once

#include <vector>

#include "autocal/pose2d.h"
#include "autocal/report/gates.h"
#include "autocal/report/run_record.h"

namespace autocal {
namespace report {

/// The pose the encoders give, dead-reckoned (odometry::DeadReckoning) with one wheel radius and
/// a baseline [m]: what the robot believes its path was (x forward at the first sample, y left).
struct PathPoint {
  double t_s = 0;
  Pose2D pose;
};
std::vector<PathPoint> believedPath(const RunRecord& record, double wheel_radius_m,
                                    double baseline_m);
/// The simulator's true path in the believed path's frame (x forward, y left at the true pose of
/// the first encoder sample, or the first true pose when that came later); empty without true
/// poses or encoder readings.
std::vector<PathPoint> truePath(const RunRecord& record);

/// The believed path with the wheels the run knows best: the odometry stage's per-wheel distances
/// per pulse and wheelbase when it is DONE (its figures left_m_per_pulse, right_m_per_pulse,
/// wheelbase_m), else one radius and baseline from the options. With one radius, wheels of
/// different diameters (Ed ≠ 1) bend every straight drive of the path.
std::vector<PathPoint> believedPath(const RunRecord& record, const ReportOptions& options);

/// The length of a path [m]: the sum of its steps' lengths.
double pathLength(const std::vector<PathPoint>& path);

}  // namespace report
}  // namespace autocal
