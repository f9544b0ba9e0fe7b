// The camera's mount on the robot from floor tags the robot sees while it stands, drives straight
// and turns on the spot: no board, no known tag layout, no person (see ground_projection.h for the
// mount's conventions).
//
// - Height, pitch and roll: the camera is rigid on a robot standing on a flat floor, so the floor
//   is one plane in the camera's frame in every still. The corners of every tag seen (their poses
//   from the tag size) are fitted with one plane.
// - Yaw: levelled with that plane, the tags seen before and after a straight drive move against
//   the robot's forward axis. A drive that turned by dθ moved along the chord, dθ/2 off the start
//   heading.
// - Offsets: a turn on the spot turns the levelled view about the middle of the wheel axle; the
//   fixed point of the tags' motion is where the axle's middle is, seen from the camera.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "autocal/extrinsics/ground_projection.h"

namespace autocal {
namespace extrinsics {

/// One tag seen in a still: its pose in the camera's optical frame (x = rotation·x_tag +
/// translation_m; the tag's z axis into the floor) and its edge.
struct TagSeen {
  int id = -1;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
  double size_m = 0.065;
};

/// The tags seen while the robot stood still once.
struct TagStill {
  std::vector<TagSeen> tags;
};

/// What the robot did between two stills.
enum class StillMotion { kForward, kBackward, kSpin };

struct StillPair {
  int before = 0, after = 0;  ///< indices into the stills
  StillMotion motion = StillMotion::kForward;
  /// A drive made with the calibrated trim: straight. Its turn is taken as none, not measured by
  /// the tags; such drives alone give the yaw when there are min_straight of them.
  bool straight = false;
};

struct TagMountOptions {
  double min_drive_m = 0.1;    ///< a straight drive shorter than this says little about the yaw
  double min_spin_rad = 0.15;  ///< a turn smaller than this says little about the axle's place
  int min_straight = 1;        ///< straight drives needed (with a tag seen before and after)
  /// The yaw from the drives flagged straight alone: fewer than min_straight of them (with a tag
  /// seen before and after) is a CalibrationError. Otherwise, with fewer, the yaw comes from every
  /// drive's chord at half its measured turn, which holds only where a drive turned evenly along
  /// its length.
  bool straight_only = false;
  int min_spins = 2;           ///< turns on the spot needed
  /// A drive made with the calibrated trim is taken as straight (no turn) unless the tags seen
  /// before and after say it turned by more than this [rad]: a robot's short hops turn by a few
  /// degrees as one wheel starts late (static friction, gearbox play, late commands), and the
  /// camera's yaw from such a hop needs the turn; below it, the tags' angles are noise. For a hop
  /// whose stills share two tags or more; one tag's angle alone is noisier, and a turn it sees
  /// counts from √2 times this. A hop that turned gives the yaw through its measured turn, whose
  /// error the tags' lever multiplies: it counts only where fewer than min_straight hops stayed
  /// within this.
  double max_straight_turn_rad = 0.01;
  /// The turn per metre driven forward [rad/m, counter-clockwise] that a drive known to be
  /// straight is taken to have where the tags see none above max_straight_turn_rad: 0 = none. A
  /// drive commanded with wheel speeds whose right/left ratio is 1 + e turns by e / wheelbase per
  /// metre; the camera's yaw moves with it (TagMountResult::yaw_per_turn_per_m).
  double straight_turn_per_m = 0;

  /// Throws ConfigError naming the bad key.
  void validate() const;
};

struct TagMountResult {
  CameraMount mount;
  double plane_rms_m = 0;     ///< the tags' corners off the fitted floor plane
  int corners = 0;            ///< in the plane fit
  int rejected = 0;           ///< tag sightings left out: far off the plane the others make
  int straight = 0;           ///< straight drives used for the yaw
  int spins = 0;              ///< turns used for the offsets
  double yaw_spread_rad = 0;  ///< standard deviation of the drives' yaws
  double centre_rms_m = 0;    ///< the turns' residual about the fitted axle centre
  /// One standard deviation of each of the mount's numbers (delete-one jackknife over the stills);
  /// has_sigma is false when fewer than three stills could each be left out.
  CameraMount sigma;
  bool has_sigma = false;
  /// How the yaw moves with TagMountOptions::straight_turn_per_m [rad per rad/m]: the straight
  /// drives' turn, taken as none, is as uncertain as the trim they were driven with, and the tags
  /// far ahead of the axle move aside with it (about 0.35 m of yaw per rad/m). Where a later
  /// calibration finds the drives turned by c per metre, the yaw was off by about
  /// yaw_per_turn_per_m · c (mountForStraightTurn).
  double yaw_per_turn_per_m = 0;
};

/// `mount` (from mountFromTags with the straight drives taken to turn by none) as it is had they
/// turned by `turn_per_m` per metre: the yaw moved by yaw_per_turn_per_m · turn_per_m, the
/// camera's offsets turned with it about the axle's middle.
CameraMount mountForStraightTurn(const CameraMount& mount, double yaw_per_turn_per_m,
                                 double turn_per_m);

/// Where floorSigmaM is judged: a floor point this far ahead of the camera [m], about where a lane
/// follower looks.
constexpr double kFloorSigmaDistanceM = 0.5;

/// How far one standard deviation of the mount (`sigma`, e.g. TagMountResult::sigma) moves the
/// floor point `distance_m` straight ahead of the camera mounted at `mount` [m]: the yaw and the
/// offsets aside and along, the pitch and the height along (a ray α below the horizon meets the
/// floor at h/tan α), added in quadrature. Roll moves a point straight ahead only to second order.
double floorSigmaM(const CameraMount& mount, const CameraMount& sigma, double distance_m);

/// The mount from the stills and the motions between them. Throws CalibrationError naming what is
/// missing (no tag, too few straight drives or turns with a tag seen before and after).
TagMountResult mountFromTags(const std::vector<TagStill>& stills,
                             const std::vector<StillPair>& pairs, const TagMountOptions& options);

}  // namespace extrinsics
}  // namespace autocal
