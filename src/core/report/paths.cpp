// The believed and the true path of a run; see paths.h.
#include "autocal/report/paths.h"

#include <cmath>

#include "autocal/odometry/dead_reckoning.h"

namespace autocal {
namespace report {

namespace {

std::vector<PathPoint> deadReckoned(const RunRecord& record,
                                    const odometry::DiffDriveParams& wheels) {
  std::vector<PathPoint> path;
  if (record.encoders.empty()) return path;
  odometry::DeadReckoning odometry(wheels, odometry::Integrator::kRungeKutta2);
  path.push_back({record.encoders.front().stamp_s, odometry.pose()});
  for (size_t i = 1; i < record.encoders.size(); ++i) {
    const EncoderSample &a = record.encoders[i - 1], &b = record.encoders[i];
    odometry.addPulses(b.left - a.left, b.right - a.right);
    path.push_back({b.stamp_s, odometry.pose()});
  }
  return path;
}

}  // namespace

std::vector<PathPoint> believedPath(const RunRecord& record, double wheel_radius_m,
                                    double baseline_m) {
  if (record.ticks_per_revolution <= 0) return {};
  return deadReckoned(record, odometry::DiffDriveParams::fromWheel(
                                  2 * wheel_radius_m, record.ticks_per_revolution, baseline_m));
}

std::vector<PathPoint> believedPath(const RunRecord& record, const ReportOptions& options) {
  const StageRecord* odometry = record.stage("odometry");
  if (odometry && odometry->state == StageState::kDone) {
    const odometry::DiffDriveParams wheels{odometry->figure("left_m_per_pulse"),
                                           odometry->figure("right_m_per_pulse"),
                                           odometry->figure("wheelbase_m")};
    if (wheels.left_m_per_pulse > 0 && wheels.right_m_per_pulse > 0 && wheels.wheelbase_m > 0)
      return deadReckoned(record, wheels);  // NaN figures fail the comparisons
  }
  return believedPath(record, options.wheel_radius_m, options.baseline_m);
}

std::vector<PathPoint> truePath(const RunRecord& record) {
  std::vector<PathPoint> path;
  if (record.true_poses.empty() || record.encoders.empty()) return path;
  // The true pose when the believed path starts: the last one at or before its first reading.
  const double start_s = record.encoders.front().stamp_s;
  Pose2D origin = record.true_poses.front().second;
  for (const auto& [t, pose] : record.true_poses) {
    if (t > start_s) break;
    origin = pose;
  }
  const double c = std::cos(origin.yaw_rad), s = std::sin(origin.yaw_rad);
  path.push_back({start_s, Pose2D()});
  for (const auto& [t, pose] : record.true_poses) {
    if (t <= start_s) continue;
    const double dx = pose.x_m - origin.x_m, dy = pose.y_m - origin.y_m;
    path.push_back({t,
                    {c * dx + s * dy, -s * dx + c * dy,
                     std::remainder(pose.yaw_rad - origin.yaw_rad, 2 * M_PI)}});
  }
  return path;
}

double pathLength(const std::vector<PathPoint>& path) {
  double length = 0;
  for (size_t i = 1; i < path.size(); ++i)
    length += std::hypot(path[i].pose.x_m - path[i - 1].pose.x_m,
                         path[i].pose.y_m - path[i - 1].pose.y_m);
  return length;
}

}  // namespace report
}  // namespace autocal
