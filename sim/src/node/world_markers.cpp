#include "world_markers.h"

#include <algorithm>
#include <cmath>

#include "autocal/sim/scene.h"
#include "autocal_ros/msg_conversion.h"

namespace autocal {
namespace sim {

namespace {

using visualization_msgs::Marker;

std_msgs::ColorRGBA color(double r, double g, double b, double a = 1.0) {
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(r);
  c.g = static_cast<float>(g);
  c.b = static_cast<float>(b);
  c.a = static_cast<float>(a);
  return c;
}

std_msgs::ColorRGBA rgb255(const std::vector<double>& c) {
  return c.size() == 3 ? color(c[0] / 255, c[1] / 255, c[2] / 255) : color(0.5, 0.5, 0.5);
}

/// A box centred at (x, y, z) turned by yaw, of size (sx along yaw, sy, sz).
Marker box(const std::string& frame, const std::string& ns, int id, double x, double y, double z,
           double yaw, double sx, double sy, double sz, const std_msgs::ColorRGBA& c) {
  Marker m;
  m.header.frame_id = frame;
  m.ns = ns;
  m.id = id;
  m.type = Marker::CUBE;
  m.action = Marker::ADD;
  m.pose = ros_layer::toPoseMsg(Pose2{x, y, yaw});
  m.pose.position.z = z;
  m.scale.x = sx;
  m.scale.y = sy;
  m.scale.z = sz;
  m.color = c;
  return m;
}

}  // namespace

visualization_msgs::MarkerArray worldMarkers(const WorldConfig& world,
                                             const std::string& world_frame) {
  visualization_msgs::MarkerArray out;
  const std::string& f = world_frame;
  // The floor: under everything the world holds, with a margin.
  double x0 = std::min(0.0, world.robot_start.x_m), x1 = x0, y0 = world.robot_start.y_m, y1 = y0;
  auto extend = [&](double x, double y) {
    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  };
  for (const WallConfig& w : world.walls) extend(w.x0_m, w.y0_m), extend(w.x1_m, w.y1_m);
  for (const ChessboardConfig& b : world.chessboards) extend(b.pose.x_m, b.pose.y_m);
  for (const FloorTagConfig& t : world.floor_tags) extend(t.pose.x_m, t.pose.y_m);
  for (const LaneLineConfig& l : world.lane_lines) extend(l.x0_m, l.y0_m), extend(l.x1_m, l.y1_m);
  for (const ObstacleConfig& o : world.obstacles) extend(o.pose.x_m, o.pose.y_m);
  const double margin = 0.2;
  out.markers.push_back(box(f, "floor", 0, 0.5 * (x0 + x1), 0.5 * (y0 + y1), -0.0025, 0,
                            x1 - x0 + 2 * margin, y1 - y0 + 2 * margin, 0.005,
                            rgb255(world.floor_color)));

  int id = 0;
  for (const WallConfig& w : world.walls) {
    const double dx = w.x1_m - w.x0_m, dy = w.y1_m - w.y0_m;
    out.markers.push_back(box(f, "walls", id++, 0.5 * (w.x0_m + w.x1_m), 0.5 * (w.y0_m + w.y1_m),
                              0.5 * w.height_m, std::atan2(dy, dx), std::hypot(dx, dy),
                              w.thickness_m, w.height_m, color(0.75, 0.72, 0.65)));
  }
  id = 0;
  for (const ChessboardConfig& b : world.chessboards) {
    // A thin plate across the direction its printed side faces.
    out.markers.push_back(box(f, "chessboards", id++, b.pose.x_m, b.pose.y_m, b.center_z_m,
                              b.pose.yaw_rad, 0.005, boardWidth(b), boardHeight(b),
                              color(0.95, 0.95, 0.95)));
  }
  id = 0;
  for (const FloorTagConfig& t : world.floor_tags) {
    // The black square (its white border is the floor's business in RViz).
    out.markers.push_back(box(f, "floor_tags", id, t.pose.x_m, t.pose.y_m, 0.001, t.pose.yaw_rad,
                              t.size_m, t.size_m, 0.002, color(0.05, 0.05, 0.05)));
    Marker label =
        box(f, "tag_ids", id++, t.pose.x_m, t.pose.y_m, 0.06, 0, 0, 0, 0.04, color(1.0, 0.3, 0.1));
    label.type = Marker::TEXT_VIEW_FACING;
    label.text = std::to_string(t.id);
    out.markers.push_back(label);
  }
  id = 0;
  for (const LaneLineConfig& l : world.lane_lines) {
    const double dx = l.x1_m - l.x0_m, dy = l.y1_m - l.y0_m, len = std::hypot(dx, dy);
    const double ux = dx / len, uy = dy / len;
    const std_msgs::ColorRGBA c = l.color == "yellow" ? color(0.95, 0.8, 0.1) : color(1, 1, 1);
    // Dashes as the renderer draws them: dash_m on, gap_m off, from (x0, y0).
    const double period = l.dash_m > 0 ? l.dash_m + l.gap_m : len;
    for (double s0 = 0; s0 < len; s0 += period) {
      const double s1 = std::min(len, s0 + (l.dash_m > 0 ? l.dash_m : len));
      const double s = 0.5 * (s0 + s1);
      out.markers.push_back(box(f, "lane_lines", id++, l.x0_m + s * ux, l.y0_m + s * uy, 0.001,
                                std::atan2(dy, dx), s1 - s0, l.width_m, 0.002, c));
    }
  }
  id = 0;
  for (const ObstacleConfig& o : world.obstacles) {
    out.markers.push_back(box(f, "obstacles", id++, o.pose.x_m, o.pose.y_m, 0.5 * o.height_m,
                              o.pose.yaw_rad, o.length_m, o.width_m, o.height_m, rgb255(o.color)));
  }
  return out;
}

visualization_msgs::MarkerArray robotMarkers(const RobotConfig& robot,
                                             const std::string& base_frame) {
  visualization_msgs::MarkerArray out;
  const std::string& f = base_frame;
  const double r = 0.5 * (robot.wheel_radius_left + robot.wheel_radius_right);
  Marker chassis =
      box(f, "robot", 0, robot.chassis_offset_x_m, 0, r + 0.03, 0, robot.chassis_length_m,
          robot.chassis_width_m, 0.06, color(0.2, 0.35, 0.8, 0.8));
  out.markers.push_back(chassis);
  int id = 1;
  for (const double side : {1.0, -1.0}) {
    const double radius = side > 0 ? robot.wheel_radius_left : robot.wheel_radius_right;
    Marker wheel = box(f, "robot", id++, 0, side * 0.5 * robot.wheelbase, radius, 0, 2 * radius,
                       2 * radius, 0.02, color(0.1, 0.1, 0.1));
    wheel.type = Marker::CYLINDER;
    // The cylinder's axis (z) along the axle (y).
    wheel.pose.orientation.x = std::sqrt(0.5);
    wheel.pose.orientation.y = 0;
    wheel.pose.orientation.z = 0;
    wheel.pose.orientation.w = std::sqrt(0.5);
    out.markers.push_back(wheel);
  }
  // The camera, tilted down by its pitch.
  Marker camera = box(f, "robot", id++, robot.camera.x_m, robot.camera.y_m, robot.camera.height_m,
                      0, 0.02, 0.03, 0.02, color(0.9, 0.2, 0.2));
  camera.pose.orientation.x = 0;
  camera.pose.orientation.y = std::sin(0.5 * robot.camera.pitch_rad);
  camera.pose.orientation.z = 0;
  camera.pose.orientation.w = std::cos(0.5 * robot.camera.pitch_rad);
  out.markers.push_back(camera);
  for (Marker& m : out.markers) m.frame_locked = true;
  return out;
}

}  // namespace sim
}  // namespace autocal
