// The camera's mount from floor tags seen in stills between straight drives and turns on the spot
// (see tag_mount.h).
#include "autocal/extrinsics/tag_mount.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include "autocal/errors.h"
#include "autocal/io/format.h"

namespace autocal {
namespace extrinsics {

void TagMountOptions::validate() const {
  if (!(min_drive_m > 0)) throw ConfigError("min_drive_m: must be > 0 [m]");
  if (!(min_spin_rad > 0 && min_spin_rad < M_PI))
    throw ConfigError("min_spin_rad: must be within (0, pi) [rad]");
  if (min_straight < 1) throw ConfigError("min_straight: must be >= 1");
  if (min_spins < 1) throw ConfigError("min_spins: must be >= 1");
  if (!(max_straight_turn_rad >= 0)) throw ConfigError("max_straight_turn_rad: must be >= 0 [rad]");
  if (!(std::abs(straight_turn_per_m) < 1))
    throw ConfigError("straight_turn_per_m: must be within (-1, 1) [rad/m]");
}

namespace {

double wrap(double a) { return std::remainder(a, 2 * M_PI); }

Eigen::Matrix2d rot(double a) {
  Eigen::Matrix2d r;
  r << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  return r;
}

/// A tag in the levelled camera frame: where it lies on the floor and where its x axis points.
struct LevelTag {
  Eigen::Vector2d at;
  double angle = 0;
};

/// How the levelled view moved between two stills: a point at g_after is at R(turn)·g_after +
/// shift before (the robot turned by `turn`, the camera moved by `shift`).
struct ViewMotion {
  int tags = 0;
  double turn = 0;
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  /// The tags' mean displacement: the shift had the robot not turned.
  Eigen::Vector2d shift_straight = Eigen::Vector2d::Zero();
  /// The shared tags' mean place after and before: the shift for another turn t is
  /// centre_before − R(t)·centre_after.
  Eigen::Vector2d centre_after = Eigen::Vector2d::Zero(), centre_before = Eigen::Vector2d::Zero();
};

ViewMotion viewMotion(const std::map<int, LevelTag>& before, const std::map<int, LevelTag>& after) {
  ViewMotion m;
  double s = 0, c = 0;
  for (const auto& [id, b] : before) {
    const auto a = after.find(id);
    if (a == after.end()) continue;
    s += std::sin(b.angle - a->second.angle);
    c += std::cos(b.angle - a->second.angle);
    ++m.tags;
  }
  if (m.tags == 0) return m;
  m.turn = std::atan2(s, c);
  for (const auto& [id, b] : before) {
    const auto a = after.find(id);
    if (a != after.end()) m.shift += (b.at - rot(m.turn) * a->second.at) / m.tags;
    if (a == after.end()) continue;
    m.centre_after += a->second.at / m.tags;
    m.centre_before += b.at / m.tags;
  }
  m.shift_straight = m.centre_before - m.centre_after;
  return m;
}

/// The corners of a tag sighting in the camera's frame.
std::array<Eigen::Vector3d, 4> cornersOf(const TagSeen& t) {
  const double h = 0.5 * t.size_m;
  std::array<Eigen::Vector3d, 4> out;
  const Eigen::Vector2d local[4] = {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
  for (int k = 0; k < 4; ++k)
    out[k] = t.rotation * Eigen::Vector3d(local[k].x(), local[k].y(), 0) + t.translation_m;
  return out;
}

/// The floor: one plane through every corner of every sighting; `up` its normal towards the
/// camera, the camera `height_m` above it.
struct FloorPlane {
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  double height_m = 0;
  int corners = 0;
  double rms_m = 0;
  /// A sighting's corners' RMS distance from the plane.
  double offPlane(const TagSeen& t) const {
    double sq = 0;
    for (const Eigen::Vector3d& c : cornersOf(t)) sq += std::pow(up.dot(c) + height_m, 2);
    return std::sqrt(sq / 4);
  }
};

FloorPlane fitFloor(const std::vector<TagStill>& stills) {
  std::vector<Eigen::Vector3d> corners;
  for (const TagStill& still : stills) {
    for (const TagSeen& t : still.tags) {
      for (const Eigen::Vector3d& c : cornersOf(t)) corners.push_back(c);
    }
  }
  if (corners.size() < 12) {
    throw CalibrationError(
        "the camera mount needs floor tags in view: " + std::to_string(corners.size() / 4) +
        " tag sightings in " + std::to_string(stills.size()) + " stills");
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : corners) centroid += p / static_cast<double>(corners.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : corners) scatter += (p - centroid) * (p - centroid).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  FloorPlane f;
  f.up = eig.eigenvectors().col(0);          // the smallest spread: the plane's normal
  if (f.up.dot(centroid) > 0) f.up = -f.up;  // towards the camera, which is above the floor
  f.height_m = -f.up.dot(centroid);
  double sq = 0;
  for (const auto& p : corners) sq += std::pow(f.up.dot(p) + f.height_m, 2);
  f.corners = static_cast<int>(corners.size());
  f.rms_m = std::sqrt(sq / static_cast<double>(corners.size()));
  return f;
}

/// The mount from every still and motion (the estimate mountFromTags reports). Drives flagged
/// straight that the tags say turned give the yaw only with_turned.
TagMountResult solveMount(const std::vector<TagStill>& all_stills,
                          const std::vector<StillPair>& pairs, const TagMountOptions& options,
                          bool with_turned) {
  TagMountResult out;
  FloorPlane floor = fitFloor(all_stills);
  // A sighting far off the plane the others make (a tag pose PnP got wrong, a tag not on the
  // floor) is left out of the plane and of the tags' places: more than five times the median
  // sighting's distance, and more than a millimetre.
  std::vector<double> off;
  for (const TagStill& still : all_stills)
    for (const TagSeen& t : still.tags) off.push_back(floor.offPlane(t));
  std::nth_element(off.begin(), off.begin() + static_cast<long>(off.size() / 2), off.end());
  const double limit = std::max(5 * off[off.size() / 2], 0.001);
  std::vector<TagStill> stills = all_stills;
  for (TagStill& still : stills) {
    const size_t before = still.tags.size();
    still.tags.erase(std::remove_if(still.tags.begin(), still.tags.end(),
                                    [&](const TagSeen& t) { return floor.offPlane(t) > limit; }),
                     still.tags.end());
    out.rejected += static_cast<int>(before - still.tags.size());
  }
  if (out.rejected > 0) floor = fitFloor(stills);
  const Eigen::Vector3d& up = floor.up;
  CameraMount& m = out.mount;
  m.height_m = floor.height_m;
  out.corners = floor.corners;
  out.plane_rms_m = floor.rms_m;
  // up = (−cos p·sin r, −cos p·cos r, −sin p) in the camera (ground_projection.h's rotation).
  m.pitch_rad = std::asin(std::clamp(-up.z(), -1.0, 1.0));
  m.roll_rad = std::atan2(-up.x(), -up.y());
  CameraMount level_mount = m;
  level_mount.yaw_rad = 0;
  const Eigen::Matrix3d level = cameraToRobot(level_mount);  // the robot's frame turned by −yaw

  // Each tag's place in a still's levelled view: the mean over the still's frames that saw it.
  std::vector<std::map<int, LevelTag>> views(stills.size());
  for (size_t i = 0; i < stills.size(); ++i) {
    std::map<int, std::pair<Eigen::Vector2d, Eigen::Vector3d>> sums;  // at; cos, sin, count
    for (const TagSeen& t : stills[i].tags) {
      const Eigen::Vector3d at = level * t.translation_m;
      const Eigen::Vector3d x = level * t.rotation.col(0);
      auto& [at_sum, dir_sum] =
          sums.try_emplace(t.id, Eigen::Vector2d::Zero(), Eigen::Vector3d::Zero()).first->second;
      at_sum += at.head<2>();
      dir_sum += Eigen::Vector3d(x.x(), x.y(), 0).normalized() + Eigen::Vector3d(0, 0, 1);
    }
    for (const auto& [id, sum] : sums) {
      views[i][id] = {sum.first / sum.second.z(), std::atan2(sum.second.y(), sum.second.x())};
    }
  }

  // Sort the motions: turns on the spot and straight drives with a tag seen before and after.
  std::vector<ViewMotion> spins;
  std::vector<std::pair<ViewMotion, bool>> drives;           // and whether it went forward
  std::vector<std::pair<ViewMotion, bool>> straight_drives;  // those known to be straight
  std::vector<std::pair<ViewMotion, bool>> turned_drives;    // those that turned all the same
  for (const StillPair& p : pairs) {
    if (p.before < 0 || p.after < 0 || p.before >= static_cast<int>(stills.size()) ||
        p.after >= static_cast<int>(stills.size()))
      throw InputError("a still pair names a still that is not there");
    const ViewMotion v =
        viewMotion(views[static_cast<size_t>(p.before)], views[static_cast<size_t>(p.after)]);
    if (v.tags == 0) continue;
    if (p.motion == StillMotion::kSpin) {
      if (std::abs(v.turn) >= options.min_spin_rad) spins.push_back(v);
    } else if (v.shift.norm() >= options.min_drive_m) {
      drives.push_back({v, p.motion == StillMotion::kForward});
      if (p.straight) {
        // Driven with the calibrated trim: straight, and a small turn is better taken as none
        // than from the tags' angles (a few 0.1 deg off, and a tag 0.35 m ahead moves the shift
        // by 6 mm per degree). A larger one is the hop's own (see max_straight_turn_rad).
        // One tag's angle is the noisier: a turn seen by one tag alone counts from √2 times the
        // threshold (the mean of two tags' angles has 1/√2 of one's noise).
        const double threshold = options.max_straight_turn_rad * (v.tags == 1 ? std::sqrt(2.0) : 1.0);
        if (std::abs(v.turn) <= threshold) {
          // The turn the trim they were driven with leaves (none, unless told).
          ViewMotion straight = v;
          straight.turn = options.straight_turn_per_m * v.shift_straight.norm() *
                          (p.motion == StillMotion::kForward ? 1 : -1);
          straight.shift = v.centre_before - rot(straight.turn) * v.centre_after;
          straight_drives.push_back({straight, p.motion == StillMotion::kForward});
        } else {
          turned_drives.push_back({v, p.motion == StillMotion::kForward});
        }
      }
    }
  }
  if (with_turned)
    straight_drives.insert(straight_drives.end(), turned_drives.begin(), turned_drives.end());
  // The drives known to be straight give the yaw when there are enough of them (alone, when
  // straight_only).
  if (options.straight_only || static_cast<int>(straight_drives.size()) >= options.min_straight)
    drives = straight_drives;
  out.straight = static_cast<int>(drives.size());
  out.spins = static_cast<int>(spins.size());
  if (out.spins < options.min_spins) {
    throw CalibrationError(
        "the camera's place on the robot needs " + std::to_string(options.min_spins) +
        " turns on the spot of " + formatNumber(options.min_spin_rad, 3) +
        " rad or more with a tag seen before and after, got " + std::to_string(out.spins));
  }
  if (out.straight < options.min_straight) {
    throw CalibrationError(
        "the camera's yaw needs " + std::to_string(options.min_straight) +
        (options.straight_only ? " drive(s) known to be straight" : " straight drive(s)") + " of " +
        formatNumber(options.min_drive_m, 3) + " m or more with a tag seen before and after, got " +
        std::to_string(out.straight));
  }

  // The axle's middle a in the levelled view is the turns' fixed point: a = R(turn)·a + shift.
  Eigen::MatrixXd A(2 * static_cast<Eigen::Index>(spins.size()), 2);
  Eigen::VectorXd b(2 * static_cast<Eigen::Index>(spins.size()));
  for (size_t i = 0; i < spins.size(); ++i) {
    A.block<2, 2>(2 * static_cast<Eigen::Index>(i), 0) =
        Eigen::Matrix2d::Identity() - rot(spins[i].turn);
    b.segment<2>(2 * static_cast<Eigen::Index>(i)) = spins[i].shift;
  }
  const Eigen::Vector2d axle = A.colPivHouseholderQr().solve(b);
  out.centre_rms_m = std::sqrt((A * axle - b).squaredNorm() / static_cast<double>(spins.size()));

  // Yaw: the robot's forward axis is at −yaw in the levelled view. A drive moved the axle's middle
  // (from a to R(turn)·a + shift) along its chord, turn/2 off the start heading; the camera, ahead
  // of the axle, moved by more to the side when the drive turned.
  double ys = 0, yc = 0;
  std::vector<double> yaws;
  for (const auto& [v, forward] : drives) {
    const Eigen::Vector2d moved = rot(v.turn) * axle + v.shift - axle;
    const double heading = std::atan2(moved.y(), moved.x()) + (forward ? 0.0 : M_PI);
    const double yaw = wrap(0.5 * v.turn - heading);
    yaws.push_back(yaw);
    ys += moved.norm() * std::sin(yaw), yc += moved.norm() * std::cos(yaw);
  }
  m.yaw_rad = std::atan2(ys, yc);
  double spread = 0;
  for (double y : yaws) spread += std::pow(wrap(y - m.yaw_rad), 2);
  out.yaw_spread_rad = std::sqrt(spread / static_cast<double>(yaws.size()));
  // The camera seen from the axle's middle, in the robot's frame.
  const Eigen::Vector2d camera = rot(m.yaw_rad) * (-axle);
  m.x_m = camera.x();
  m.y_m = camera.y();
  return out;
}

}  // namespace

TagMountResult mountFromTags(const std::vector<TagStill>& stills,
                             const std::vector<StillPair>& pairs, const TagMountOptions& options) {
  options.validate();
  // A drive the tags say turned gives the yaw only through that turn, whose error the tags' lever
  // multiplies (a turn 0.3 deg off moves the yaw by about 1 deg): such drives count only where
  // those taken as straight are too few, and then in every replica below too.
  bool with_turned = false;
  TagMountResult out;
  try {
    out = solveMount(stills, pairs, options, with_turned);
  } catch (const CalibrationError&) {
    with_turned = true;
    out = solveMount(stills, pairs, options, with_turned);
  }
  // One standard deviation of each number by the delete-one jackknife over the stills (Efron and
  // Tibshirani, "An Introduction to the Bootstrap", ch. 11): the solve again without one still's
  // tags (and so without the motions that start or end there). The tags of one still share its
  // pose and its noise, which a residual per corner would count as independent.
  std::vector<CameraMount> replicas;
  std::vector<TagStill> without = stills;
  // A replica needs the data to determine the mount, not the estimate's minimum of drives known to
  // be straight: a still between two drives takes both away.
  TagMountOptions replica_options = options;
  if (options.straight_only) replica_options.min_straight = 1;
  for (size_t i = 0; i < stills.size(); ++i) {
    if (stills[i].tags.empty()) continue;
    without[i].tags.clear();
    try {
      replicas.push_back(solveMount(without, pairs, replica_options, with_turned).mount);
    } catch (const CalibrationError&) {
      // Without this still the data no longer determine the mount: it adds no replica.
    }
    without[i].tags = stills[i].tags;
  }
  // The yaw's sensitivity to the straight drives' turn, by a difference of 0.01 rad/m (a trim
  // about 0.0005 off).
  const double dk = 0.01;
  TagMountOptions turned = options;
  turned.straight_turn_per_m += dk;
  out.yaw_per_turn_per_m =
      wrap(solveMount(stills, pairs, turned, with_turned).mount.yaw_rad - out.mount.yaw_rad) / dk;
  const size_t n = replicas.size();
  if (n < 3) return out;
  const CameraMount& m = out.mount;
  auto sigma = [&](auto field, bool angle) {
    double mean = 0;
    for (const CameraMount& r : replicas) {
      mean += (angle ? wrap(field(r) - field(m)) : field(r) - field(m)) / static_cast<double>(n);
    }
    double sq = 0;
    for (const CameraMount& r : replicas) {
      const double d = angle ? wrap(field(r) - field(m)) : field(r) - field(m);
      sq += (d - mean) * (d - mean);
    }
    return std::sqrt(sq * static_cast<double>(n - 1) / static_cast<double>(n));
  };
  CameraMount& s = out.sigma;
  s.height_m = sigma([](const CameraMount& r) { return r.height_m; }, false);
  s.pitch_rad = sigma([](const CameraMount& r) { return r.pitch_rad; }, true);
  s.roll_rad = sigma([](const CameraMount& r) { return r.roll_rad; }, true);
  s.yaw_rad = sigma([](const CameraMount& r) { return r.yaw_rad; }, true);
  s.x_m = sigma([](const CameraMount& r) { return r.x_m; }, false);
  s.y_m = sigma([](const CameraMount& r) { return r.y_m; }, false);
  out.has_sigma = true;
  return out;
}

CameraMount mountForStraightTurn(const CameraMount& mount, double yaw_per_turn_per_m,
                                 double turn_per_m) {
  CameraMount m = mount;
  m.yaw_rad = wrap(mount.yaw_rad + yaw_per_turn_per_m * turn_per_m);
  // The axle's middle stays where the turns put it in the levelled view: the camera, seen from
  // it in the robot's frame, turns with the yaw.
  const Eigen::Vector2d camera =
      rot(m.yaw_rad - mount.yaw_rad) * Eigen::Vector2d(mount.x_m, mount.y_m);
  m.x_m = camera.x();
  m.y_m = camera.y();
  return m;
}

double floorSigmaM(const CameraMount& mount, const CameraMount& sigma, double distance_m) {
  const double d = distance_m, h = mount.height_m;
  const double aside = std::hypot(d * sigma.yaw_rad, sigma.y_m);
  const double along = std::hypot(std::hypot(sigma.x_m, sigma.pitch_rad * (d * d + h * h) / h),
                                  sigma.height_m * d / h);
  return std::hypot(aside, along);
}

}  // namespace extrinsics
}  // namespace autocal
