#include "autocal/wheels/straight_track.h"

#include <cmath>
#include <limits>

#include "autocal/wheels/tag_heading.h"

namespace autocal {
namespace wheels {

StraightTrack::StraightTrack(const Pose2D& start) : start_(start) { track_.push_back({0.0, 0.0}); }

void StraightTrack::add(const Pose2D& pose) {
  const double dx = pose.x_m - start_.x_m, dy = pose.y_m - start_.y_m;
  const double c = std::cos(start_.yaw_rad), s = std::sin(start_.yaw_rad);
  along_m_ = c * dx + s * dy;
  lateral_m_ = -s * dx + c * dy;
  heading_rad_ = wrapAngle(pose.yaw_rad - start_.yaw_rad);
  track_.push_back({along_m_, lateral_m_});
}

double StraightTrack::lateralAtM(double distance_m) const {
  for (size_t i = 1; i < track_.size(); ++i) {
    const auto& a = track_[i - 1];
    const auto& b = track_[i];
    if (b.first >= distance_m && a.first < distance_m) {
      const double t = (distance_m - a.first) / (b.first - a.first);
      return a.second + t * (b.second - a.second);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace wheels
}  // namespace autocal
