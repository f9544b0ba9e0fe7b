// Configuration of the simulated robot and world, read from YAML (every key documented in
// sim/config/robot.yaml and sim/config/world.yaml). SI units: metres, radians, seconds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autocal/camera_intrinsics.h"
#include "autocal/distortion_model.h"
#include "autocal/pose2d.h"
#include "autocal/sim/transport.h"

namespace autocal {
namespace sim {

using autocal::DistortionModel;

/// The simulator's lenses use the one intrinsics type of autocal.
using Intrinsics = autocal::CameraIntrinsics;

struct CameraConfig {
  Intrinsics truth;    ///< what the lens really does: the renderer uses it
  Intrinsics nominal;  ///< what camera_info says (uncalibrated datasheet values)
  double noise_sigma = 2.0;  ///< Gaussian pixel noise [grey levels of 255]
  double height_m = 0.1;     ///< optical centre above the floor
  double pitch_rad = 0.3;    ///< downward tilt of the optical axis
  double x_m = 0.06;         ///< optical centre ahead of the wheel axle
  double y_m = 0.0;          ///< optical centre left of the robot's centre line
  double yaw_rad = 0.0;      ///< optical axis turned left of the robot's x axis (after pitch)
  double roll_rad = 0.0;     ///< about the optical axis; positive: the image's right side down
  double rate_hz = 30.0;
  double exposure_s = 0.02;  ///< motion during this time blurs the image
  int supersampling = 3;     ///< edge pixels get supersampling^2 samples (anti-aliasing)
  int jpeg_quality = 90;
  /// Brightness lost at the farthest image corner (falling with the squared distance from the
  /// principal point), 0..0.9.
  double vignetting = 0.0;
  /// Each frame's brightness is scaled by 1 + N(0, brightness_sigma) (auto-exposure, light).
  double brightness_sigma = 0.0;
  /// Rolling shutter: the rows are read out one after the other over this time [s], the top row
  /// first; each row's exposure ends when it is read (0: a global shutter).
  double readout_s = 0.0;
  /// The focus ring: the position at which the lens is sharp [turns], and the defocus blur (a
  /// Gaussian's sigma) per turn away from it [px/turn]. The ring stands at the sharp position
  /// unless sim_node is told otherwise at run time (<veh>/sim_lens/focus_ring_turns).
  double focus_ring_sharp_turns = 0.0;
  double defocus_px_per_turn = 4.0;
  /// Depth of field: with the ring at its sharp position the lens is sharp at focus_distance_m,
  /// and a surface at distance d is blurred by defocus_px_per_diopter·|1/d − 1/focus_distance_m|
  /// [px, a Gaussian's sigma] (a thin lens's blur circle grows with the distance from the focus
  /// in dioptres). Turning the ring moves the focus: the blur is
  /// |defocus_px_per_turn·(ring − focus_ring_sharp_turns) + defocus_px_per_diopter·(1/d − 1/focus)|.
  /// 0 (either): the blur does not depend on the distance.
  double focus_distance_m = 0.0;
  double defocus_px_per_diopter = 0.0;
};

struct RangeSensorConfig {
  double x_m = 0.09;  ///< sensor position in the robot frame (x ahead of the axle, y left)
  double y_m = 0.0;
  double yaw_rad = 0.0;            ///< direction of the cone's axis in the robot frame
  double field_of_view_rad = 0.44; ///< full cone angle
  double min_range_m = 0.03;
  double max_range_m = 2.0;
  double noise_sigma_m = 0.005;
  double rate_hz = 20.0;
  int rays = 9;  ///< rays cast across the cone; the reading is the nearest hit
};

/// How late the robot's messages arrive, and which are lost (robot YAML `transport:`).
struct TransportConfig {
  LinkConfig camera;      ///< a frame (and its camera_info) from exposure to the subscriber
  LinkConfig encoders;    ///< each wheel's encoder reading
  LinkConfig range;       ///< the range sensor's reading
  LinkConfig wheels_cmd;  ///< a wheels_cmd from its publisher to the motors
};

struct RobotConfig {
  double wheel_radius_left = 0.0318;   ///< [m] true radius
  double wheel_radius_right = 0.0318;  ///< [m]
  double wheelbase = 0.102;            ///< [m] distance between the wheels' contact points
  double motor_gain_left = 1.0;        ///< true gain of each motor (1 = nominal)
  double motor_gain_right = 1.0;
  double motor_constant = 27.0;        ///< [rad/s] wheel speed at duty 1 and gain 1
  double deadband = 0.05;              ///< duties with |d| <= deadband do not turn the wheel
  double motor_time_constant = 0.05;   ///< [s] first-order lag of the wheel speed
  int encoder_resolution = 135;        ///< ticks per wheel revolution
  double encoder_rate_hz = 30.0;
  double mass_kg = 1.2;
  double chassis_length_m = 0.18;
  double chassis_width_m = 0.13;
  double chassis_offset_x_m = -0.03;   ///< chassis centre ahead of the axle (negative: behind)
  double caster_x_m = -0.1;            ///< caster ahead of the axle (negative: behind)
  double wheel_friction = 0.8;         ///< traction limit = friction x normal load
  /// Static friction: a wheel at rest starts only above this |duty| (>= deadband); once turning
  /// it runs down to the deadband. Negative: the deadband (no static friction).
  double breakaway_duty_left = -1.0;
  double breakaway_duty_right = -1.0;
  double backward_gain_ratio_left = 1.0;  ///< gain backward / gain forward of each motor
  double backward_gain_ratio_right = 1.0;
  /// Relative change of both motors' gains per minute of simulated time (battery, temperature).
  double gain_drift_per_min = 0.0;
  /// Gearbox play at the wheel [rad]: after a reversal the motor turns through it before the
  /// wheel moves.
  double backlash_rad = 0.0;
  /// Random slip of each wheel: its contact point moves by (1 - slip) of its rim's speed, slip
  /// drawn from N(0, wheel_slip_sigma) every wheel_slip_interval_s [s].
  double wheel_slip_sigma = 0.0;
  double wheel_slip_interval_s = 0.2;
  TransportConfig transport;
  CameraConfig camera;
  RangeSensorConfig range_sensor;
};

/// The one planar pose type of autocal.
using Pose2 = autocal::Pose2D;

/// A vertical chessboard on a stand. Its printed side faces the direction yaw_rad.
struct ChessboardConfig {
  int cols = 7;  ///< inner corners along the board's width
  int rows = 5;  ///< inner corners along its height
  double square_m = 0.031;
  double margin_m = 0.02;     ///< white border around the squares
  Pose2 pose;                 ///< centre of the board on the floor plan, facing yaw_rad
  double center_z_m = 0.15;   ///< height of the board's centre above the floor
};

struct FloorTagConfig {
  int id = 0;
  double size_m = 0.065;  ///< edge of the black square (AprilTag convention)
  Pose2 pose;             ///< centre; yaw_rad is the direction of the tag's x axis (image right)
};

/// A chessboard lying flat on the floor (Duckietown's extrinsics board).
struct FloorBoardConfig {
  int cols = 7;  ///< inner corners across (to the left of yaw_rad)
  int rows = 5;  ///< inner corners along yaw_rad
  double square_m = 0.031;
  double margin_m = 0.02;  ///< white border around the squares
  Pose2 pose;              ///< centre of the squares; yaw_rad: the direction its rows count along
};

struct LaneLineConfig {
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
  double width_m = 0.05;
  std::string color = "white";  ///< white | yellow
  double dash_m = 0.0;          ///< 0: solid; else dash length, with gap_m between dashes
  double gap_m = 0.0;
};

struct WallConfig {
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
  double height_m = 0.5;
  double thickness_m = 0.05;
  uint32_t texture_seed = 1;
};

struct ObstacleConfig {
  Pose2 pose;
  double length_m = 0.1, width_m = 0.1, height_m = 0.1;
  std::vector<double> color{180, 60, 60};  ///< RGB 0..255
};

/// Light that changes across the room (a window on one side, lamps over one end): every surface's
/// colour is scaled by 1 + x_per_m * x + y_per_m * y at its world point (x, y), held to
/// [kMinLight, kMaxLight]. Zero: even light.
struct LightGradientConfig {
  static constexpr double kMinLight = 0.3, kMaxLight = 1.7;
  double x_per_m = 0, y_per_m = 0;  ///< [1/m], each within +-0.5
  double at(double x_m, double y_m) const {
    const double k = 1 + x_per_m * x_m + y_per_m * y_m;
    return k < kMinLight ? kMinLight : k > kMaxLight ? kMaxLight : k;
  }
  bool even() const { return x_per_m == 0 && y_per_m == 0; }
};

struct WorldConfig {
  Pose2 robot_start;
  std::vector<double> floor_color{150, 150, 145};  ///< RGB 0..255
  LightGradientConfig light_gradient;
  std::vector<ChessboardConfig> chessboards;
  std::vector<FloorTagConfig> floor_tags;
  std::vector<FloorBoardConfig> floor_boards;
  std::vector<LaneLineConfig> lane_lines;
  std::vector<WallConfig> walls;
  std::vector<ObstacleConfig> obstacles;
};

/// Loads and validates; throws ConfigError naming the file, line and key.
RobotConfig loadRobotConfig(const std::string& path);
WorldConfig loadWorldConfig(const std::string& path);
/// The same from YAML text (`name` stands for the file in messages).
RobotConfig parseRobotConfig(const std::string& yaml, const std::string& name);
WorldConfig parseWorldConfig(const std::string& yaml, const std::string& name);

}  // namespace sim
}  // namespace autocal
