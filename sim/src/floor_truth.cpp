#include "autocal/sim/floor_truth.h"

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <sstream>

#include "autocal/distortion_model.h"
#include "autocal/io/format.h"
#include "autocal/sim/camera_model.h"
#include "autocal/sim/scene.h"

namespace autocal {
namespace sim {

extrinsics::CameraInfoRectification trueCameraInfo(const sim::RobotConfig& robot) {
  extrinsics::CameraInfoRectification c;
  c.intrinsics = robot.camera.truth;
  const cv::Mat K(c.intrinsics.cameraMatrix());
  const cv::Mat D(c.intrinsics.distortion_coefficients);
  const cv::Mat P = cv::getOptimalNewCameraMatrix(K, D, c.intrinsics.imageSize(), 0.0);
  cv::cv2eigen(P, c.rectified.P);
  return c;
}

std::string cameraInfoYaml(const extrinsics::CameraInfoRectification& camera) {
  const CameraIntrinsics& in = camera.intrinsics;
  auto matrix = [](int rows, int cols, const std::vector<double>& data) {
    std::string s =
        "\n  rows: " + std::to_string(rows) + "\n  cols: " + std::to_string(cols) + "\n  data: [";
    for (size_t i = 0; i < data.size(); ++i) s += (i ? ", " : "") + formatNumber(data[i]);
    return s + "]\n";
  };
  const Eigen::Matrix3d& P = camera.rectified.P;
  const Eigen::Matrix3d& R = camera.rectified.R;
  std::ostringstream y;
  y << "image_width: " << in.width << "\nimage_height: " << in.height
    << "\ncamera_name: simulated\ncamera_matrix:"
    << matrix(3, 3, {in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1})
    << "distortion_model: " << distortionModelName(in.distortion_model)
    << "\ndistortion_coefficients:"
    << matrix(1, static_cast<int>(in.distortion_coefficients.size()), in.distortion_coefficients)
    << "rectification_matrix:"
    << matrix(3, 3,
              {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)})
    << "projection_matrix:"
    << matrix(3, 4,
              {P(0, 0), P(0, 1), P(0, 2), 0, P(1, 0), P(1, 1), P(1, 2), 0, P(2, 0), P(2, 1),
               P(2, 2), 0});
  return y.str();
}

bool trueFloorPixel(const sim::RobotConfig& robot, const extrinsics::RectifiedCamera& camera,
                    const Eigen::Vector2d& ground_m, Eigen::Vector2d* pixel) {
  const Eigen::Matrix3d to_robot = cameraToRobotRotation(robot.camera);
  const Eigen::Vector3d t(robot.camera.x_m, robot.camera.y_m, robot.camera.height_m);
  const Eigen::Vector3d on_floor(ground_m.x(), ground_m.y(), 0.0);
  const Eigen::Vector3d p = camera.P * camera.R * to_robot.transpose() * (on_floor - t);
  if (p.z() <= 0) return false;
  *pixel = p.hnormalized();
  return pixel->x() >= 0 && pixel->y() >= 0 && pixel->x() < robot.camera.truth.width &&
         pixel->y() < robot.camera.truth.height;
}

FloorError floorError(const sim::RobotConfig& robot, const extrinsics::RectifiedCamera& camera,
                      const Eigen::Matrix3d& H) {
  FloorError e;
  double sum = 0;
  for (int i = 0; i <= 25; ++i) {
    for (int j = -20; j <= 20; ++j) {
      const Eigen::Vector2d g(0.1 + 0.02 * i, 0.02 * j);
      Eigen::Vector2d px;
      if (!trueFloorPixel(robot, camera, g, &px)) continue;
      const double d = (extrinsics::pixelToGround(H, px) - g).norm();
      sum += d * d;
      e.max_m = std::max(e.max_m, d);
      ++e.points;
    }
  }
  e.rms_m = std::sqrt(sum / std::max(1, e.points));
  return e;
}

FloorError floorErrorThroughCalibration(const sim::RobotConfig& robot,
                                        const extrinsics::CameraInfoRectification& calibrated,
                                        const Eigen::Matrix3d& H) {
  const CameraModel lens(robot.camera.truth);
  const Eigen::Matrix3d to_robot = cameraToRobotRotation(robot.camera);
  const Eigen::Vector3d t(robot.camera.x_m, robot.camera.y_m, robot.camera.height_m);
  const CameraIntrinsics& in = calibrated.intrinsics;
  cv::Mat P, R;
  cv::eigen2cv(calibrated.rectified.P, P);
  cv::eigen2cv(calibrated.rectified.R, R);
  FloorError e;
  double sum = 0;
  for (int i = 0; i <= 25; ++i) {
    for (int j = -20; j <= 20; ++j) {
      const Eigen::Vector2d g(0.1 + 0.02 * i, 0.02 * j);
      Eigen::Vector2d raw;
      const Eigen::Vector3d p = to_robot.transpose() * (Eigen::Vector3d(g.x(), g.y(), 0.0) - t);
      if (p.z() <= 0 || !lens.project(p, &raw) || raw.x() < 0 || raw.y() < 0 ||
          raw.x() >= in.width || raw.y() >= in.height)
        continue;
      std::vector<cv::Point2d> in_px{{raw.x(), raw.y()}}, out_px;
      const cv::Mat K(in.cameraMatrix()), D(in.distortion_coefficients);
      if (in.distortion_model == DistortionModel::kEquidistant)
        cv::fisheye::undistortPoints(in_px, out_px, K, D, R, P);
      else
        cv::undistortPoints(in_px, out_px, K, D, R, P);
      const double d = (extrinsics::pixelToGround(H, {out_px[0].x, out_px[0].y}) - g).norm();
      sum += d * d;
      e.max_m = std::max(e.max_m, d);
      ++e.points;
    }
  }
  e.rms_m = std::sqrt(sum / std::max(1, e.points));
  return e;
}

std::string mountVersusTruth(const FloorError& floor, const extrinsics::CameraMount& m,
                             const CameraConfig& t) {
  char text[400];
  const double deg = 180 / M_PI;
  std::snprintf(text, sizeof text,
                "floor %.2f mm RMS, %.2f mm worst; height %.2f mm (truth %.2f), pitch %.3f deg "
                "(%.3f), roll %.3f deg (%.3f), yaw %.3f deg (%.3f), x %.2f mm (%.2f), y %.2f mm "
                "(%.2f)",
                1e3 * floor.rms_m, 1e3 * floor.max_m, 1e3 * m.height_m, 1e3 * t.height_m,
                deg * m.pitch_rad, deg * t.pitch_rad, deg * m.roll_rad, deg * t.roll_rad,
                deg * m.yaw_rad, deg * t.yaw_rad, 1e3 * m.x_m, 1e3 * t.x_m, 1e3 * m.y_m,
                1e3 * t.y_m);
  return text;
}

}  // namespace sim
}  // namespace autocal
