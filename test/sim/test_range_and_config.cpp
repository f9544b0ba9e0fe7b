// The range sensor's ray casts against the geometry, and the strict configuration reader.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "autocal/errors.h"
#include "autocal/sim/config.h"
#include "autocal/sim/simulation.h"

namespace sim = autocal::sim;

namespace {

const std::string kSource = AUTOCAL_SOURCE_DIR;

sim::RobotConfig defaultRobot() { return sim::loadRobotConfig(kSource + "/sim/config/robot_ideal.yaml"); }

sim::WorldConfig wallAt(double x) {
  sim::WorldConfig w;
  sim::WallConfig wall;
  wall.x0_m = wall.x1_m = x;
  wall.y0_m = -2;
  wall.y1_m = 2;
  wall.thickness_m = 0.04;
  w.walls.push_back(wall);
  return w;
}

TEST(SimRange, RayCastRangeEqualsTheGeometry) {
  const sim::RobotConfig robot = defaultRobot();
  for (double x : {0.4, 0.9, 1.6}) {
    sim::Simulation s(robot, wallAt(x), sim::SimulationOptions());
    // Sensor at x_m ahead of the axle facing the wall head-on; the wall's face is thickness/2
    // before its centre line. The cone's nearest ray is the central one.
    const double expected = x - 0.02 - robot.range_sensor.x_m;
    EXPECT_NEAR(s.trueRange(), expected, 1e-4) << "wall at " << x;
    // Readings scatter around it with the configured noise.
    std::mt19937_64 rng(4);
    double sum = 0, sum2 = 0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
      const double r = s.measureRange(rng);
      sum += r;
      sum2 += r * r;
    }
    const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
    EXPECT_NEAR(mean, expected, 4 * robot.range_sensor.noise_sigma_m / std::sqrt(n));
    EXPECT_NEAR(sd, robot.range_sensor.noise_sigma_m, 0.1 * robot.range_sensor.noise_sigma_m);
  }
}

TEST(SimRange, ObliqueWallUsesTheNearestRayOfTheCone) {
  sim::RobotConfig robot = defaultRobot();
  sim::WorldConfig w = wallAt(1.0);
  w.robot_start.yaw_rad = 0.3;  // the wall is 0.3 rad off the sensor's axis
  sim::Simulation s(robot, w, sim::SimulationOptions());
  const double sx = robot.range_sensor.x_m * std::cos(0.3);
  const double half_fov = 0.5 * robot.range_sensor.field_of_view_rad;
  // The ray at the cone's edge nearest the wall's normal: angle 0.3 - half_fov from it.
  const double expected = (1.0 - 0.02 - sx) / std::cos(0.3 - half_fov);
  EXPECT_NEAR(s.trueRange(), expected, 1e-4);
}

TEST(SimRange, NothingInRangeIsInfinityAndTooCloseIsMinusInfinity) {
  sim::RobotConfig robot = defaultRobot();
  robot.range_sensor.noise_sigma_m = 0;
  sim::Simulation far(robot, wallAt(5.0), sim::SimulationOptions());
  std::mt19937_64 rng(1);
  EXPECT_TRUE(std::isinf(far.trueRange()));
  EXPECT_EQ(far.measureRange(rng), std::numeric_limits<double>::infinity());
  robot.range_sensor.min_range_m = 0.5;
  sim::Simulation near(robot, wallAt(0.4), sim::SimulationOptions());
  EXPECT_EQ(near.measureRange(rng), -std::numeric_limits<double>::infinity());
}

TEST(SimRange, ObstacleOutsideTheConeIsNotSeen) {
  sim::RobotConfig robot = defaultRobot();
  sim::WorldConfig w;
  sim::ObstacleConfig box;
  box.pose = {0.6, 0.5, 0};  // 40 degrees off axis
  box.length_m = box.width_m = 0.1;
  w.obstacles.push_back(box);
  sim::Simulation s(robot, w, sim::SimulationOptions());
  EXPECT_TRUE(std::isinf(s.trueRange()));
  w.obstacles[0].pose = {0.6, 0.05, 0};
  sim::Simulation t(robot, w, sim::SimulationOptions());
  EXPECT_NEAR(t.trueRange(), 0.6 - 0.05 - robot.range_sensor.x_m, 0.01);
}

// --- configuration -------------------------------------------------------------------------

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The message of the ConfigError that parsing `yaml` throws ("" when it does not throw).
std::string robotError(const std::string& yaml) {
  try {
    sim::parseRobotConfig(yaml, "robot_ideal.yaml");
  } catch (const autocal::ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(SimConfig, ShippedConfigsLoad) {
  const sim::RobotConfig r = defaultRobot();
  EXPECT_EQ(r.encoder_resolution, 135);
  EXPECT_EQ(r.camera.truth.distortion_coefficients.size(), 5u);
  EXPECT_NE(r.camera.truth.fx, r.camera.nominal.fx) << "camera_info must not carry the truth";
  const sim::WorldConfig w = sim::loadWorldConfig(kSource + "/sim/config/world.yaml");
  EXPECT_GE(w.chessboards.size(), 2u);
  EXPECT_GE(w.floor_tags.size(), 3u);
  // Floor tags 15 cm apart, 6.5 cm, all oriented the same way (paper 000 section 3.1).
  for (size_t i = 1; i < w.floor_tags.size(); ++i) {
    const auto& a = w.floor_tags[i - 1].pose;
    const auto& b = w.floor_tags[i].pose;
    EXPECT_NEAR(std::hypot(a.x_m - b.x_m, a.y_m - b.y_m), 0.15, 1e-9);
    EXPECT_EQ(a.yaw_rad, b.yaw_rad);
    EXPECT_EQ(w.floor_tags[i].size_m, 0.065);
  }
}

TEST(SimConfig, UnknownKeyIsAnErrorNamingFileLineAndKey) {
  const std::string base = slurp(kSource + "/sim/config/robot_ideal.yaml");
  const std::string msg = robotError(replaced(base, "  jpeg_quality: 90", "  jpeg_quality: 90\n  jpeg_qualty: 80"));
  EXPECT_NE(msg.find("robot_ideal.yaml:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("camera.jpeg_qualty: unknown key"), std::string::npos) << msg;
  const std::string top = robotError(base + "\nwheel_radius: 0.03\n");
  EXPECT_NE(top.find("wheel_radius: unknown key"), std::string::npos) << top;
}

TEST(SimConfig, MotorImperfectionsAndTransportAreReadAndChecked) {
  const sim::RobotConfig ideal = defaultRobot();
  EXPECT_EQ(ideal.breakaway_duty_left, ideal.deadband) << "robot_ideal.yaml's robot is ideal";
  EXPECT_FALSE(ideal.transport.camera.active());
  EXPECT_FALSE(ideal.transport.wheels_cmd.active());
  const sim::RobotConfig real = sim::loadRobotConfig(kSource + "/sim/config/robot.yaml");
  EXPECT_GT(real.breakaway_duty_left, real.deadband);
  EXPECT_GT(real.breakaway_duty_right, real.deadband);
  EXPECT_LT(real.gain_drift_per_min, 0.0);
  EXPECT_NE(real.backward_gain_ratio_left, 1.0);
  EXPECT_GT(real.backlash_rad, 0.0);
  EXPECT_GT(real.wheel_slip_sigma, 0.0);
  EXPECT_GE(real.transport.camera.latency_s, 0.05);
  EXPECT_GT(real.transport.camera.drop_probability, 0.0);
  EXPECT_GT(real.transport.encoders.latency_s, 0.0);
  EXPECT_GT(real.transport.wheels_cmd.latency_s, 0.0);
  EXPECT_GT(real.camera.readout_s, 0.0);
  EXPECT_EQ(real.camera.truth.distortion_model, sim::DistortionModel::kEquidistant);

  const std::string base = slurp(kSource + "/sim/config/robot_ideal.yaml");
  // Without the keys: none of it.
  std::string bare = replaced(base, "breakaway_duty_left: 0.08", "");
  bare = replaced(bare, "  camera: {latency_s: 0.0, jitter_s: 0.0, drop_probability: 0.0}", "");
  const sim::RobotConfig r = sim::parseRobotConfig(bare, "robot_ideal.yaml");
  EXPECT_EQ(r.breakaway_duty_left, r.deadband);
  EXPECT_FALSE(r.transport.camera.active());
  const sim::RobotConfig weak_back = sim::parseRobotConfig(
      replaced(base, "backward_gain_ratio_left: 1.0", "backward_gain_ratio_left: 0.95"),
      "robot_ideal.yaml");
  EXPECT_EQ(weak_back.backward_gain_ratio_left, 0.95);
  EXPECT_EQ(weak_back.backward_gain_ratio_right, 1.0);
  EXPECT_EQ(r.backlash_rad, 0.0);
  EXPECT_EQ(r.wheel_slip_sigma, 0.0);
  const sim::RobotConfig worn = sim::parseRobotConfig(
      replaced(replaced(base, "backlash_rad: 0.0", "backlash_rad: 0.04"), "wheel_slip_sigma: 0.0",
               "wheel_slip_sigma: 0.01"),
      "robot_ideal.yaml");
  EXPECT_EQ(worn.backlash_rad, 0.04);
  EXPECT_EQ(worn.wheel_slip_sigma, 0.01);
  EXPECT_EQ(r.camera.readout_s, 0.0);
  // A rolling shutter reads its rows within a frame period (30 Hz: 33 ms).
  EXPECT_EQ(sim::parseRobotConfig(replaced(base, "readout_s: 0.0 ", "readout_s: 0.03 "), "robot.yaml")
                .camera.readout_s,
            0.03);
  EXPECT_NE(robotError(replaced(base, "readout_s: 0.0 ", "readout_s: 0.04 ")).find("readout_s: must be shorter"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "backlash_rad: 0.0", "backlash_rad: -0.01")).find("backlash_rad"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "wheel_slip_sigma: 0.0", "wheel_slip_sigma: 0.5"))
                .find("wheel_slip_sigma"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "breakaway_duty_left: 0.08", "breakaway_duty_left: 0.05"))
                .find("breakaway_duty_left: must be in [deadband"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "camera: {latency_s: 0.0,", "camera: {latency_ms: 0.0,"))
                .find("transport.camera.latency_ms: unknown key"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "  range: {latency_s: 0.0", "  rnge: {latency_s: 0.0"))
                .find("transport.rnge: unknown key"),
            std::string::npos);
  EXPECT_NE(robotError(
                replaced(base, "wheels_cmd: {latency_s: 0.0, jitter_s: 0.0, drop_probability: 0.0}",
                         "wheels_cmd: {drop_probability: 0.9}"))
                .find("drop_probability: must be in"),
            std::string::npos);
}

TEST(SimConfig, MalformedOrMissingValuesAreErrors) {
  const std::string base = slurp(kSource + "/sim/config/robot_ideal.yaml");
  EXPECT_NE(robotError(replaced(base, "wheelbase: 0.102", "wheelbase: abc")).find("wheelbase: expected a number, got 'abc'"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "wheelbase: 0.102", "wheelbase: -0.1")).find("wheelbase: must be > 0"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "wheelbase: 0.102", "wheelbase: .nan")).find("wheelbase"), std::string::npos);
  EXPECT_NE(robotError(replaced(base, "encoder_resolution: 135", "encoder_resolution: 13.5")).find("encoder_resolution"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "wheelbase: 0.102  ", "#")).find("wheelbase: required key is missing"),
            std::string::npos);
  EXPECT_NE(robotError(replaced(base, "distortion_coefficients: [-0.27, 0.065, 0.0011, -0.0007, 0.0]",
                                "distortion_coefficients: [-0.27, 0.065]"))
                .find("plumb_bob takes 5 coefficients"),
            std::string::npos);
  EXPECT_NE(robotError("camera: [1, 2\n").find("not valid YAML"), std::string::npos);
  EXPECT_THROW(sim::loadRobotConfig("/nonexistent/robot_ideal.yaml"), autocal::ConfigError);
}

// Tags placed by a person: each off its listed place by N(0, sigma) in x, y and yaw, from the seed.
TEST(SimConfig, FloorTagPlacementErrorsMoveTheTagsBySigmaFromTheSeed) {
  const std::string base = slurp(kSource + "/sim/config/world.yaml");
  const sim::WorldConfig nominal = sim::parseWorldConfig(base, "world.yaml");
  const std::string placed_yaml =
      replaced(base, "floor_tag_placement: {position_sigma_m: 0.0, yaw_sigma_rad: 0.0, seed: 1}",
               "floor_tag_placement: {position_sigma_m: 0.004, yaw_sigma_rad: 0.03, seed: 3}");
  const sim::WorldConfig placed = sim::parseWorldConfig(placed_yaml, "world.yaml");
  const sim::WorldConfig again = sim::parseWorldConfig(placed_yaml, "world.yaml");
  const sim::WorldConfig other = sim::parseWorldConfig(
      replaced(placed_yaml, "yaw_sigma_rad: 0.03, seed: 3", "yaw_sigma_rad: 0.03, seed: 4"),
      "world.yaml");
  ASSERT_EQ(placed.floor_tags.size(), nominal.floor_tags.size());
  ASSERT_GE(placed.floor_tags.size(), 5u);
  double position2 = 0, yaw2 = 0;
  for (size_t i = 0; i < placed.floor_tags.size(); ++i) {
    const sim::Pose2 &p = placed.floor_tags[i].pose, &n = nominal.floor_tags[i].pose;
    position2 += std::pow(p.x_m - n.x_m, 2) + std::pow(p.y_m - n.y_m, 2);
    yaw2 += std::pow(p.yaw_rad - n.yaw_rad, 2);
    EXPECT_EQ(p.x_m, again.floor_tags[i].pose.x_m);
    EXPECT_EQ(p.yaw_rad, again.floor_tags[i].pose.yaw_rad);
    EXPECT_NE(p.yaw_rad, other.floor_tags[i].pose.yaw_rad);
  }
  const double n = static_cast<double>(placed.floor_tags.size());
  EXPECT_GT(std::sqrt(position2 / (2 * n)), 0.4 * 0.004);
  EXPECT_LT(std::sqrt(position2 / (2 * n)), 1.8 * 0.004);
  EXPECT_GT(std::sqrt(yaw2 / n), 0.4 * 0.03);
  EXPECT_LT(std::sqrt(yaw2 / n), 1.8 * 0.03);
  EXPECT_THROW(sim::parseWorldConfig(replaced(placed_yaml, "position_sigma_m: 0.004",
                                              "position_sigma_m: 0.5"),
                                     "world.yaml"),
               autocal::ConfigError);
}

TEST(SimConfig, WorldErrorsNameTheListEntry) {
  try {
    sim::parseWorldConfig("chessboards:\n  - {cols: 7, rows: 5, square_m: 0.03, x_m: 1, y_m: 0, center_z_m: 0.15, colour: red}\n",
                          "world.yaml");
    FAIL() << "no error";
  } catch (const autocal::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("world.yaml:2: chessboards[0].colour: unknown key"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(sim::parseWorldConfig("floor_tags:\n  - {id: 999, size_m: 0.065, x_m: 0, y_m: 0}\n", "w"),
               autocal::ConfigError);
}

}  // namespace
