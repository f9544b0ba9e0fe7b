// The renderer against the geometry it draws: OpenCV's and libapriltag's detectors, run on the
// rendered images, must find the boards' corners and the tags where the true camera puts them.
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/sim/camera_model.h"
#include "autocal/sim/config.h"
#include "autocal/sim/projection_difference.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/scene.h"

namespace sim = autocal::sim;

namespace {

sim::RobotConfig defaultRobot() {
  return sim::loadRobotConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/robot_ideal.yaml");
}
sim::WorldConfig defaultWorld() {
  return sim::loadWorldConfig(std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/world.yaml");
}

sim::RenderOptions optionsOf(const sim::CameraConfig& c) {
  sim::RenderOptions o;
  o.supersampling = c.supersampling;
  o.noise_sigma = c.noise_sigma;
  return o;
}

cv::Mat cameraMatrix(const sim::Intrinsics& in) {
  return (cv::Mat_<double>(3, 3) << in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1);
}

/// Pixels where the true camera images these world points (through cv::projectPoints, not through
/// the simulator's own projection).
std::vector<cv::Point2f> projectTruth(const sim::CameraConfig& cam, const sim::Pose2& pose,
                                      const std::vector<Eigen::Vector3d>& world_points) {
  const Eigen::Isometry3d cam_from_world = sim::cameraInWorld(cam, pose).inverse();
  std::vector<cv::Point3d> pts;
  for (const auto& p : world_points) {
    const Eigen::Vector3d q = cam_from_world * p;
    pts.emplace_back(q.x(), q.y(), q.z());
  }
  std::vector<cv::Point2f> out;
  const cv::Mat K = cameraMatrix(cam.truth);
  const cv::Mat D(cam.truth.distortion_coefficients, true);
  if (cam.truth.distortion_model == sim::DistortionModel::kEquidistant) {
    std::vector<cv::Point2d> out_d;
    cv::fisheye::projectPoints(pts, out_d, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
    for (const auto& p : out_d) out.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  } else {
    std::vector<cv::Point2d> out_d;
    cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, out_d);
    for (const auto& p : out_d) out.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  }
  return out;
}

/// RMS distance [px] from each detected corner to the nearest true one.
double matchRms(const std::vector<cv::Point2f>& detected, const std::vector<cv::Point2f>& truth) {
  double sum = 0;
  for (const auto& d : detected) {
    double best = 1e18;
    for (const auto& t : truth) best = std::min(best, double(cv::norm(d - t)));
    sum += best * best;
  }
  return std::sqrt(sum / detected.size());
}

struct BoardView {
  int board;
  sim::Pose2 pose;
};

/// Renders, detects the board with OpenCV (sub-pixel) and returns the RMS against the truth.
double boardCornerRms(const sim::RobotConfig& robot, const sim::WorldConfig& world, const BoardView& view,
                      uint64_t seed) {
  sim::Renderer renderer(robot.camera, world, optionsOf(robot.camera));
  std::mt19937_64 rng(seed);
  const cv::Mat image = renderer.render({view.pose}, rng);
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  const sim::ChessboardConfig& b = world.chessboards[view.board];
  const std::vector<cv::Point2f> truth = projectTruth(robot.camera, view.pose, sim::chessboardCorners(b));
  // Keep only this board in the image: mask everything far from its true corners, so that other
  // boards in view cannot be found instead.
  cv::Rect box = cv::boundingRect(truth);
  box.x -= 40;
  box.y -= 40;
  box.width += 80;
  box.height += 80;
  box &= cv::Rect(0, 0, gray.cols, gray.rows);
  cv::Mat roi(gray.size(), gray.type(), cv::Scalar(128));
  gray(box).copyTo(roi(box));
  std::vector<cv::Point2f> corners;
  const bool found = cv::findChessboardCorners(roi, cv::Size(b.cols, b.rows), corners,
                                               cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  EXPECT_TRUE(found) << "board " << view.board << " not detected";
  if (!found) return 1e9;
  EXPECT_EQ(corners.size(), truth.size());
  cv::cornerSubPix(roi, corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  return matchRms(corners, truth);
}

// The projection difference of a calibrated model against the true lens, on known cases: the lens
// itself gives 0 everywhere; a focal length off by dfx moves pixel u by dfx (u - cx) / fx; a
// principal point off by dcy moves every pixel by dcy; a distortion that only the image's corners
// feel leaves the centre alone.
/// The default robot's pinhole (its true fx, fy, cx, cy), no distortion.
sim::Intrinsics defaultPinhole() {
  sim::Intrinsics in;
  in.fx = 318;
  in.fy = 320.5;
  in.cx = 325.4;
  in.cy = 236.8;
  return in;
}

TEST(ProjectionDifference, KnownModelErrors) {
  sim::Intrinsics lens = defaultPinhole();
  lens.distortion_coefficients = {-0.27, 0.065, 0.0011, -0.0007, 0.001};
  const sim::ProjectionDifference same = sim::projectionDifference(lens, lens);
  EXPECT_EQ(same.pixels, 80 * 60);
  EXPECT_EQ(same.unmapped, 0);
  EXPECT_LT(same.worst_px, 1e-6);

  sim::Intrinsics pinhole = lens;
  pinhole.distortion_coefficients = {0, 0, 0, 0, 0};
  sim::Intrinsics wider = pinhole;
  wider.fx += 3;
  double sum = 0;
  int n = 0;
  for (double v = 4; v < 480; v += 8)
    for (double u = 4; u < 640; u += 8, ++n) sum += std::pow(3 * (u - pinhole.cx) / pinhole.fx, 2);
  const sim::ProjectionDifference fx = sim::projectionDifference(pinhole, wider);
  EXPECT_NEAR(fx.rms_px, std::sqrt(sum / n), 1e-6);
  EXPECT_NEAR(fx.worst_px, 3 * (pinhole.cx - 4) / pinhole.fx, 1e-6);

  sim::Intrinsics lower = pinhole;
  lower.cy += 2;
  const sim::ProjectionDifference cy = sim::projectionDifference(pinhole, lower);
  EXPECT_NEAR(cy.rms_px, 2, 1e-6);
  EXPECT_NEAR(cy.upper_rms_px, 2, 1e-6);
  EXPECT_NEAR(cy.lower_rms_px, 2, 1e-6);

  sim::Intrinsics k3 = lens;
  k3.distortion_coefficients[4] += 0.05;  // r^6: 0.05 r^6, tiny near the centre
  const sim::ProjectionDifference corners = sim::projectionDifference(lens, k3);
  EXPECT_LT(corners.centre_rms_px, 0.05);
  EXPECT_GT(corners.worst_px, 1.0);
  // ... and worst in a corner of the grid.
  EXPECT_TRUE(corners.worst_u_px == 4 || corners.worst_u_px == 636) << corners.worst_u_px;
  EXPECT_TRUE(corners.worst_v_px == 4 || corners.worst_v_px == 476) << corners.worst_v_px;
  EXPECT_THROW(sim::projectionDifference(lens, lens, 0), autocal::ConfigError);
}

TEST(SimRenderer, CameraModelMatchesOpenCvProjection) {
  sim::Intrinsics in = defaultPinhole();
  const std::vector<std::pair<sim::DistortionModel, std::vector<double>>> models = {
      {sim::DistortionModel::kPlumbBob, {-0.27, 0.065, 0.0011, -0.0007, 0.001}},
      {sim::DistortionModel::kRationalPolynomial, {0.3, -0.1, 0.001, -0.002, 0.01, 0.6, -0.05, 0.02}},
      {sim::DistortionModel::kEquidistant, {0.05, -0.01, 0.004, -0.001}}};
  std::mt19937_64 rng(3);
  // Points within the field of view where each model is one-to-one (|x/z|, |y/z| <= 0.8).
  std::uniform_real_distribution<double> xy(-0.8, 0.8), z(1.0, 3.0);
  for (const auto& [model, coeffs] : models) {
    in.distortion_model = model;
    in.distortion_coefficients = coeffs;
    sim::CameraConfig cam;
    cam.truth = in;
    const sim::CameraModel m(in);
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
      Eigen::Vector2d mine;
      ASSERT_TRUE(m.project(p, &mine));
      // Compare with OpenCV (camera at the world origin: pose identity for a camera-frame point).
      std::vector<cv::Point3d> pts{{p.x(), p.y(), p.z()}};
      std::vector<cv::Point2d> cvp;
      if (model == sim::DistortionModel::kEquidistant) {
        cv::fisheye::projectPoints(pts, cvp, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cameraMatrix(in),
                                   cv::Mat(coeffs, true));
      } else {
        cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cameraMatrix(in), cv::Mat(coeffs, true), cvp);
      }
      EXPECT_NEAR(mine.x(), cvp[0].x, 1e-6);
      EXPECT_NEAR(mine.y(), cvp[0].y, 1e-6);
      // And the ray through that pixel points back at the point.
      Eigen::Vector3d ray;
      ASSERT_TRUE(m.ray(mine.x(), mine.y(), &ray));
      EXPECT_NEAR(ray.dot(p.normalized()), 1.0, 1e-12) << distortionModelName(model) << " " << p.transpose();
    }
  }
}

TEST(SimRenderer, ChessboardCornersLandWhereTheTrueCameraProjectsThem) {
  const sim::RobotConfig robot = defaultRobot();
  const sim::WorldConfig world = defaultWorld();
  // Boards straight ahead, turned, near the image edge (strong distortion), and seen obliquely.
  const std::vector<BoardView> views = {{2, {0, 0, 0.0}},   {1, {0, 0, -0.75}}, {3, {0, 0, 0.72}},
                                        {2, {0, 0, 0.45}},  {0, {0.02, 0.01, -1.3}}, {4, {0, 0, 1.5}}};
  double worst = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    const double rms = boardCornerRms(robot, world, views[i], 100 + i);
    std::cout << "view " << i << ": corner RMS " << rms << " px" << std::endl;
    RecordProperty("board_rms_px_" + std::to_string(i), std::to_string(rms));
    EXPECT_LT(rms, 0.15) << "view " << i << " (board " << views[i].board << ")";
    worst = std::max(worst, rms);
  }
  std::cout << "worst corner RMS " << worst << " px" << std::endl;
}

TEST(SimRenderer, FisheyeCameraRendersTrueCornersToo) {
  sim::RobotConfig robot = defaultRobot();
  robot.camera.truth.distortion_model = sim::DistortionModel::kEquidistant;
  robot.camera.truth.distortion_coefficients = {0.02, -0.005, 0.001, 0.0};
  robot.camera.truth.fx = robot.camera.truth.fy = 270;
  const double rms = boardCornerRms(robot, defaultWorld(), {2, {0, 0, 0.0}}, 7);
  EXPECT_LT(rms, 0.15);
}

// A rolling shutter (robot YAML camera.readout_s): each band of rows is seen from the pose of its
// own readout time. A robot turning at 1 rad/s with a 30 ms readout: board 2's corners, found by
// OpenCV in the frame, lie where the true camera at their row's time projects them (not where it
// does at the frame's end, 4-9 px away), as the simulation's bands give the times.
TEST(SimRenderer, RollingShutterSeesEachRowAtItsReadoutTime) {
  sim::RobotConfig robot = defaultRobot();
  robot.camera.readout_s = 0.03;
  robot.camera.exposure_s = 0.0;
  const sim::WorldConfig world = defaultWorld();
  sim::Renderer renderer(robot.camera, world, optionsOf(robot.camera));
  const int band_rows = renderer.rollingBandRows(), height = robot.camera.truth.height;
  const double yaw_rate = 1.0, end_yaw = 0.0;  // board 2 straight ahead when the readout ends
  std::vector<std::vector<sim::Pose2>> bands;
  std::vector<sim::Pose2> band_pose;
  for (int v0 = 0; v0 < height; v0 += band_rows) {
    const double middle = 0.5 * (v0 + std::min(height, v0 + band_rows));
    const double t = -robot.camera.readout_s * (1.0 - middle / height);  // as Simulation's bands
    band_pose.push_back({0, 0, end_yaw + yaw_rate * t});
    bands.push_back({band_pose.back()});
  }
  std::mt19937_64 rng(3);
  cv::Mat gray;
  cv::cvtColor(renderer.renderRolling(bands, rng), gray, cv::COLOR_BGR2GRAY);
  const sim::ChessboardConfig& b = world.chessboards[2];
  const std::vector<cv::Point2f> at_end =
      projectTruth(robot.camera, {0, 0, end_yaw}, sim::chessboardCorners(b));
  // Only this board: the rest of the image grey (as boardCornerRms does).
  cv::Rect box = cv::boundingRect(at_end);
  box = cv::Rect(box.x - 40, box.y - 40, box.width + 80, box.height + 80) &
        cv::Rect(0, 0, gray.cols, gray.rows);
  cv::Mat roi(gray.size(), gray.type(), cv::Scalar(128));
  gray(box).copyTo(roi(box));
  gray = roi;
  std::vector<cv::Point2f> corners;
  ASSERT_TRUE(cv::findChessboardCorners(gray, cv::Size(b.cols, b.rows), corners,
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE));
  cv::cornerSubPix(gray, corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  double sum2 = 0, worst = 0, sum2_end = 0;
  for (const cv::Point2f& c : corners) {
    const int band = std::clamp(static_cast<int>(c.y) / band_rows, 0, static_cast<int>(bands.size()) - 1);
    const std::vector<cv::Point2f> truth =
        projectTruth(robot.camera, band_pose[static_cast<size_t>(band)], sim::chessboardCorners(b));
    double best = 1e18, best_end = 1e18;
    for (size_t i = 0; i < truth.size(); ++i) {
      best = std::min(best, static_cast<double>(cv::norm(c - truth[i])));
      best_end = std::min(best_end, static_cast<double>(cv::norm(c - at_end[i])));
    }
    sum2 += best * best;
    sum2_end += best_end * best_end;
    worst = std::max(worst, best);
  }
  const double rms = std::sqrt(sum2 / corners.size()), rms_end = std::sqrt(sum2_end / corners.size());
  std::cout << "corners against their row's time: RMS " << rms << " px, worst " << worst
            << " px; against the readout's end: RMS " << rms_end << " px" << std::endl;
  EXPECT_LT(rms, 0.3);
  EXPECT_LT(worst, 0.8);
  EXPECT_GT(rms_end, 3.0);
}

// Light that changes across the room: each floor point is as bright as the gradient says at its
// world position, against the same world in even light (the points' pixels from cv::projectPoints
// of the true camera, not from the simulator's projection).
TEST(SimRenderer, LightGradientScalesEachSurfaceByItsWorldPoint) {
  const sim::RobotConfig robot = defaultRobot();
  sim::RenderOptions o = optionsOf(robot.camera);
  o.noise_sigma = 0;
  sim::WorldConfig even;  // the bare floor
  sim::WorldConfig lit = even;
  lit.light_gradient.x_per_m = -0.4;
  lit.light_gradient.y_per_m = 0.3;
  sim::Renderer a(robot.camera, even, o), b(robot.camera, lit, o);
  std::mt19937_64 rng(1);
  const sim::Pose2 pose{0, 0, 0};
  cv::Mat plain, shaded;
  cv::cvtColor(a.render({pose}, rng), plain, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b.render({pose}, rng), shaded, cv::COLOR_BGR2GRAY);
  const std::vector<Eigen::Vector3d> points{
      {0.25, 0.1, 0}, {0.9, -0.3, 0}, {0.5, 0.4, 0}, {0.6, 0.0, 0}};
  const std::vector<cv::Point2f> pixels = projectTruth(robot.camera, pose, points);
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Rect box(cvRound(pixels[i].x) - 2, cvRound(pixels[i].y) - 2, 5, 5);
    ASSERT_TRUE((box & cv::Rect(0, 0, plain.cols, plain.rows)) == box) << "point " << i;
    const double ratio = cv::mean(shaded(box))[0] / cv::mean(plain(box))[0];
    const double truth = lit.light_gradient.at(points[i].x(), points[i].y());
    EXPECT_NEAR(ratio, truth, 0.02 * truth) << "point " << i;
  }
}

// Depth of field (robot YAML camera.focus_distance_m, defocus_px_per_diopter): a surface at
// distance d is blurred by k·|1/d − 1/focus|. Board 2 seen from where it is in focus and from 0.4 m
// farther back: over the board, the frame matches the sharp image blurred by the sigma the board's
// true distance gives better than by half or one and a half times it (and in focus, the sharp
// image itself).
TEST(SimRenderer, DepthOfFieldBlursBySurfaceDistance) {
  sim::RobotConfig robot = defaultRobot();
  robot.camera.noise_sigma = 0;
  const sim::WorldConfig world = defaultWorld();
  const sim::ChessboardConfig& b = world.chessboards[2];
  const std::vector<Eigen::Vector3d> corners = sim::chessboardCorners(b);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& c : corners) centre += c / static_cast<double>(corners.size());
  const sim::Pose2 near{0, 0, 0}, far{-0.4, 0, 0};
  auto distance = [&](const sim::Pose2& p) {
    return (sim::cameraInWorld(robot.camera, p).translation() - centre).norm();
  };
  robot.camera.focus_distance_m = distance(near);
  robot.camera.defocus_px_per_diopter = 2.0;
  auto mismatch = [&](const sim::Pose2& pose, double sigma_px) {
    sim::Renderer renderer(robot.camera, world, optionsOf(robot.camera));
    std::mt19937_64 rng(1);
    cv::Mat frame;
    renderer.render({pose}, rng).convertTo(frame, CV_32FC3);
    cv::Mat sharp = renderer.renderExact(pose), expected = sharp;
    if (sigma_px > 0) cv::GaussianBlur(sharp, expected, cv::Size(), sigma_px);
    cv::Rect box = cv::boundingRect(projectTruth(robot.camera, pose, corners));
    box = cv::Rect(box.x + 3, box.y + 3, box.width - 6, box.height - 6);
    return cv::mean(cv::abs(frame(box) - expected(box)))[0];
  };
  const double far_sigma =
      2.0 * std::abs(1.0 / distance(far) - 1.0 / robot.camera.focus_distance_m);
  std::cout << "board at " << distance(near) << " m (in focus) and " << distance(far)
            << " m: sigma " << far_sigma << " px" << std::endl;
  ASSERT_GT(far_sigma, 0.8);
  const double near_sharp = mismatch(near, 0), near_blurred = mismatch(near, far_sigma);
  const double far_true = mismatch(far, far_sigma), far_half = mismatch(far, 0.5 * far_sigma),
               far_more = mismatch(far, 1.5 * far_sigma), far_sharp = mismatch(far, 0);
  std::cout << "in focus: against sharp " << near_sharp << ", blurred " << near_blurred
            << "; farther: against its sigma " << far_true << ", half " << far_half
            << ", 1.5 times " << far_more << ", sharp " << far_sharp << std::endl;
  EXPECT_LT(near_sharp, 0.5 * near_blurred);
  EXPECT_LT(far_true, far_half);
  EXPECT_LT(far_true, far_more);
  EXPECT_LT(far_true, 0.5 * far_sharp);
}

TEST(SimRenderer, FloorTagIsDetectedWithItsIdAndTruePose) {
  const sim::RobotConfig robot = defaultRobot();
  const sim::WorldConfig world = defaultWorld();
  sim::Renderer renderer(robot.camera, world, optionsOf(robot.camera));
  // Facing the tag strip from the start position.
  const sim::Pose2 pose{-0.02, 0.01, M_PI - 0.05};
  std::mt19937_64 rng(5);
  const cv::Mat image = renderer.render({pose}, rng);
  cv::Mat gray, rectified;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  // The lens bends the tags' straight edges; libapriltag fits straight lines, so detect on the
  // image rectified with the TRUE intrinsics (DESIGN: tag poses from undistorted corners).
  const cv::Mat K = cameraMatrix(robot.camera.truth);
  const cv::Mat D(robot.camera.truth.distortion_coefficients, true);
  cv::undistort(gray, rectified, K, D, K);

  apriltag_family_t* family = tag36h11_create();
  apriltag_detector_t* detector = apriltag_detector_create();
  apriltag_detector_add_family(detector, family);
  detector->quad_decimate = 1.0;
  image_u8_t im{rectified.cols, rectified.rows, static_cast<int32_t>(rectified.step), rectified.data};
  zarray_t* detections = apriltag_detector_detect(detector, &im);

  const Eigen::Isometry3d cam_from_world = sim::cameraInWorld(robot.camera, pose).inverse();
  std::set<int> seen;
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    ASSERT_GE(det->id, 0);
    ASSERT_LT(det->id, static_cast<int>(world.floor_tags.size())) << "a tag id that is not in the world";
    const sim::FloorTagConfig& tag = world.floor_tags[det->id];
    seen.insert(det->id);
    // Corners in libapriltag's order land on the true tag's corners in that order (projected
    // by the pinhole K: the image is rectified).
    const auto corners = sim::tagCorners(tag);
    std::vector<cv::Point3d> cam_pts;
    for (const auto& c : corners) {
      const Eigen::Vector3d q = cam_from_world * c;
      cam_pts.emplace_back(q.x(), q.y(), q.z());
    }
    std::vector<cv::Point2d> truth;
    cv::projectPoints(cam_pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, cv::noArray(), truth);
    for (int k = 0; k < 4; ++k) {
      EXPECT_LT(cv::norm(cv::Point2d(det->p[k][0], det->p[k][1]) - truth[k]), 1.0)
          << "tag " << det->id << " corner " << k;
    }
    if (det->id > 1) continue;  // pose accuracy for the near tags that wheel calibration uses
    // Pose from the detected corners and the TRUE intrinsics.
    const double h = 0.5 * tag.size_m;
    const std::vector<cv::Point3d> object{{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
    std::vector<cv::Point2d> pixels;
    for (int k = 0; k < 4; ++k) pixels.emplace_back(det->p[k][0], det->p[k][1]);
    cv::Vec3d rvec, tvec;
    ASSERT_TRUE(cv::solvePnP(object, pixels, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE));
    cv::Matx33d Rcv;
    cv::Rodrigues(rvec, Rcv);
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R(r, c) = Rcv(r, c);
    const Eigen::Isometry3d truth_pose = cam_from_world * sim::tagInWorld(tag);
    const double position_error = (Eigen::Vector3d(tvec[0], tvec[1], tvec[2]) - truth_pose.translation()).norm();
    const double angle_error = Eigen::AngleAxisd(R.transpose() * truth_pose.linear()).angle();
    std::cout << "tag " << det->id << ": position error " << position_error * 1000 << " mm, angle error "
              << angle_error * 180 / M_PI << " deg" << std::endl;
    EXPECT_LT(position_error, 0.01) << "tag " << det->id;
    EXPECT_LT(angle_error, M_PI / 180) << "tag " << det->id;
  }
  // The tags within 0.4 m of the camera have cells of 2 px or more: they must be found. (Tag 2,
  // 0.5 m away, is seen so obliquely that its cells are about 1 px tall: undecodable.)
  EXPECT_TRUE(seen.count(0) && seen.count(1)) << "the nearest tags were not all detected";
  apriltag_detections_destroy(detections);
  apriltag_detector_destroy(detector);
  tag36h11_destroy(family);
}

TEST(SimRenderer, SameSeedSameImageOtherSeedOtherNoise) {
  const sim::RobotConfig robot = defaultRobot();
  sim::Renderer renderer(robot.camera, defaultWorld(), optionsOf(robot.camera));
  std::mt19937_64 a(9), b(9), c(10);
  const cv::Mat ia = renderer.render({{0, 0, 0.2}}, a), ib = renderer.render({{0, 0, 0.2}}, b),
                ic = renderer.render({{0, 0, 0.2}}, c);
  EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(ia, ic, cv::NORM_INF), 0.0);
  // The noise has the configured standard deviation.
  cv::Mat diff;
  cv::subtract(ia, ic, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff.reshape(1), mean, stddev);
  EXPECT_NEAR(stddev[0] / std::sqrt(2.0), robot.camera.noise_sigma, 0.2 * robot.camera.noise_sigma);
}

// Vignetting darkens a pixel by `vignetting` times its squared distance from the principal point
// over the farthest corner's; a frame's brightness scales by 1 + N(0, brightness_sigma).
TEST(SimRenderer, VignettingAndBrightnessScaleThePixelsAsConfigured) {
  sim::RobotConfig robot = defaultRobot();
  robot.camera.noise_sigma = 0;
  sim::RobotConfig shaded = robot;
  shaded.camera.vignetting = 0.4;
  sim::Renderer plain(robot.camera, defaultWorld(), optionsOf(robot.camera));
  sim::Renderer dark(shaded.camera, defaultWorld(), optionsOf(shaded.camera));
  std::mt19937_64 rng(1);
  const std::vector<sim::Pose2> pose{{0, 0, 0.1}};
  cv::Mat a, b;
  plain.render(pose, rng).convertTo(a, CV_64FC3);
  dark.render(pose, rng).convertTo(b, CV_64FC3);
  const sim::Intrinsics& in = robot.camera.truth;
  double corner2 = 0;
  for (double u : {-0.5, in.width - 0.5}) {
    for (double v : {-0.5, in.height - 0.5}) {
      corner2 = std::max(corner2, (u - in.cx) * (u - in.cx) + (v - in.cy) * (v - in.cy));
    }
  }
  int checked = 0;
  for (int v = 0; v < in.height; v += 7) {
    for (int u = 0; u < in.width; u += 7) {
      const double lit = a.at<cv::Vec3d>(v, u)[1];
      if (lit < 60) continue;  // rounding dominates dark pixels
      const double r2 = (u - in.cx) * (u - in.cx) + (v - in.cy) * (v - in.cy);
      // Both images rounded to whole grey levels: within half a level each.
      ASSERT_NEAR(b.at<cv::Vec3d>(v, u)[1], lit * (1 - 0.4 * r2 / corner2), 1.0) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);

  sim::RobotConfig varying = robot;
  varying.camera.brightness_sigma = 0.1;
  sim::Renderer flicker(varying.camera, defaultWorld(), optionsOf(varying.camera));
  cv::Mat green;
  cv::extractChannel(a, green, 1);
  const cv::Mat mask = (green < 200) & (green > 20);  // not saturated when brightened
  std::vector<double> ratios;
  for (int k = 0; k < 40; ++k) {
    cv::Mat f;
    flicker.render(pose, rng).convertTo(f, CV_64FC3);
    ratios.push_back(cv::mean(f, mask)[1] / cv::mean(a, mask)[1]);
  }
  double mean = 0, var = 0;
  for (double r : ratios) mean += r / ratios.size();
  for (double r : ratios) var += (r - mean) * (r - mean) / (ratios.size() - 1);
  EXPECT_NEAR(mean, 1.0, 0.05);
  EXPECT_NEAR(std::sqrt(var), 0.1, 0.035);
}

TEST(SimRenderer, MotionDuringExposureBlursTheImage) {
  const sim::RobotConfig robot = defaultRobot();
  sim::Renderer renderer(robot.camera, defaultWorld(), optionsOf(robot.camera));
  std::mt19937_64 rng(1);
  auto sharpness = [](const cv::Mat& bgr) {
    cv::Mat gray, lap;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    cv::Laplacian(gray, lap, CV_32F);
    cv::Scalar m, s;
    cv::meanStdDev(lap, m, s);
    return s[0];
  };
  const cv::Mat still = renderer.render({{0, 0, 0}}, rng);
  std::vector<sim::Pose2> turning;
  for (int k = 0; k < 8; ++k) turning.push_back({0, 0, 0.004 * k});  // ~1.3 px per sample
  const cv::Mat blurred = renderer.render(turning, rng);
  EXPECT_LT(sharpness(blurred), 0.7 * sharpness(still));
  EXPECT_EQ(renderer.blurredFramesHalfRes(), 1u);  // 8 poses: at half resolution
}

// A blurred frame of many poses is rendered at half resolution and scaled up: it must land where
// the full-resolution poses put the scene (no half-pixel shift from the scaling) and look alike.
// Four poses that coincide isolate the resolution from the motion; the boards' corners, found in
// both images, measure where they land: on average within 0.2 px (a scaling off by half a pixel
// would shift them by 0.25-0.5 px), each within 1.5 px (neither image's poses are anti-aliased,
// and the half-resolution ones step in 2 px).
TEST(SimRenderer, HalfResolutionBlurLandsWhereFullResolutionPosesDo) {
  const sim::RobotConfig robot = defaultRobot();
  sim::RenderOptions half = optionsOf(robot.camera), full = half;
  half.noise_sigma = full.noise_sigma = 0;
  full.blur_half_res_poses = 0;
  // Without the boards lying on the floor: their small squares, seen at a grazing angle, alias
  // differently at the two resolutions and would dominate the mean difference.
  sim::WorldConfig world = defaultWorld();
  world.floor_boards.clear();
  sim::Renderer halved(robot.camera, world, half), whole(robot.camera, world, full);
  std::mt19937_64 rng(1);
  int boards = 0;
  for (const double yaw : {0.0, 0.5, -2.6}) {  // boards; boards and a wall; the floor tags
    const std::vector<sim::Pose2> poses(4, sim::Pose2{0, 0, yaw});
    cv::Mat a, b;
    cv::cvtColor(halved.render(poses, rng), a, cv::COLOR_BGR2GRAY);
    cv::cvtColor(whole.render(poses, rng), b, cv::COLOR_BGR2GRAY);
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    EXPECT_LT(cv::mean(diff)[0], 4.0) << "yaw " << yaw;
    std::vector<cv::Point2f> ca, cb;
    if (!cv::findChessboardCorners(a, cv::Size(7, 5), ca) ||
        !cv::findChessboardCorners(b, cv::Size(7, 5), cb)) {
      continue;
    }
    ++boards;
    const cv::TermCriteria stop(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 0.001);
    cv::cornerSubPix(a, ca, cv::Size(5, 5), cv::Size(-1, -1), stop);
    cv::cornerSubPix(b, cb, cv::Size(5, 5), cv::Size(-1, -1), stop);
    cv::Point2f mean_shift(0, 0);
    for (size_t i = 0; i < ca.size(); ++i) {
      EXPECT_LT(cv::norm(ca[i] - cb[i]), 1.5) << "yaw " << yaw << " corner " << i;
      mean_shift += (ca[i] - cb[i]) * (1.0f / static_cast<float>(ca.size()));
    }
    EXPECT_LT(cv::norm(mean_shift), 0.2) << "yaw " << yaw << ": " << mean_shift;
  }
  EXPECT_GE(boards, 2);
  EXPECT_EQ(halved.blurredFramesHalfRes(), 3u);
  EXPECT_EQ(whole.blurredFramesHalfRes(), 0u);
}

}  // namespace

namespace {

sim::RenderOptions withReuse(const sim::CameraConfig& c, double still_reuse_px) {
  sim::RenderOptions o = optionsOf(c);
  o.still_reuse_px = still_reuse_px;
  return o;
}

}  // namespace

// A still frame that reuses the last still frame's noiseless image is the frame a renderer that
// renders every frame anew gives with the same noise draw.
TEST(SimRendererStillReuse, ReusedStillFrameEqualsAFreshRender) {
  const sim::RobotConfig robot = defaultRobot();
  const sim::WorldConfig world = defaultWorld();
  sim::Renderer reusing(robot.camera, world, withReuse(robot.camera, 0.01));
  sim::Renderer fresh(robot.camera, world, withReuse(robot.camera, -1));
  std::mt19937_64 a(21), b(21);
  const sim::Pose2 pose{0.05, -0.02, 0.3};
  for (int k = 0; k < 3; ++k) {
    const cv::Mat ia = reusing.render({pose}, a), ib = fresh.render({pose}, b);
    EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0) << "frame " << k;
  }
  EXPECT_EQ(reusing.stillFramesRendered(), 1u);
  EXPECT_EQ(reusing.stillFramesReused(), 2u);
  EXPECT_EQ(fresh.stillFramesRendered(), 3u);
  EXPECT_EQ(fresh.stillFramesReused(), 0u);
}

// The noise of consecutive frames of a robot standing still is fresh: two frames differ by two
// independent noise draws (standard deviation sqrt(2) sigma), not by zero.
// With a depth of field, a reused still frame keeps its own blur, also after a blurred frame in
// between: it equals the same still rendered by a fresh renderer.
TEST(SimRendererStillReuse, ReusedStillKeepsItsDepthOfFieldBlur) {
  sim::RobotConfig robot = defaultRobot();
  robot.camera.noise_sigma = 0;
  robot.camera.focus_distance_m = 0.4;
  robot.camera.defocus_px_per_diopter = 2.0;
  sim::Renderer renderer(robot.camera, defaultWorld(), optionsOf(robot.camera));
  std::mt19937_64 rng(1);
  renderer.render({{0, 0, 0}}, rng);
  std::vector<sim::Pose2> turning;
  for (int k = 0; k < 8; ++k) turning.push_back({0, 0, 0.004 * k});
  renderer.render(turning, rng);
  const cv::Mat again = renderer.render({{0, 0, 0}}, rng);
  EXPECT_EQ(renderer.stillFramesReused(), 1u);
  sim::Renderer fresh(robot.camera, defaultWorld(), optionsOf(robot.camera));
  const cv::Mat expected = fresh.render({{0, 0, 0}}, rng);
  EXPECT_EQ(cv::norm(again, expected, cv::NORM_INF), 0.0);
}

TEST(SimRendererStillReuse, ConsecutiveStillFramesHaveFreshNoise) {
  const sim::RobotConfig robot = defaultRobot();
  sim::Renderer renderer(robot.camera, defaultWorld(), optionsOf(robot.camera));
  std::mt19937_64 rng(5);
  const sim::Pose2 pose{0, 0, -0.4};
  const cv::Mat first = renderer.render({pose}, rng), second = renderer.render({pose}, rng);
  EXPECT_EQ(renderer.stillFramesReused(), 1u);
  cv::Mat diff;
  cv::subtract(first, second, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff.reshape(1), mean, stddev);
  EXPECT_NEAR(stddev[0] / std::sqrt(2.0), robot.camera.noise_sigma, 0.2 * robot.camera.noise_sigma);
}

// The reused image belongs to the pose: a pose that moves the image by more than the tolerance
// (here 0.03 px and 3 px), a blurred frame in between, and a pose within it behave as they must.
TEST(SimRendererStillReuse, PoseChangeBeyondTheToleranceRendersAnew) {
  const sim::RobotConfig robot = defaultRobot();
  const sim::WorldConfig world = defaultWorld();
  sim::Renderer reusing(robot.camera, world, withReuse(robot.camera, 0.01));
  sim::Renderer fresh(robot.camera, world, withReuse(robot.camera, -1));
  std::mt19937_64 a(3), b(3);
  const double px_per_rad = robot.camera.truth.fx;
  const sim::Pose2 p0{0, 0, 0.1};
  const sim::Pose2 p1{0, 0, 0.1 + 0.03 / px_per_rad};  // the image turns by about 0.03 px
  const sim::Pose2 p2{0, 0, 0.1 + 3.0 / px_per_rad};   // ... by about 3 px
  std::vector<sim::Pose2> blur;
  for (int k = 0; k < 4; ++k) blur.push_back({0, 0, 0.1 + 0.004 * k});
  for (const std::vector<sim::Pose2>& poses : std::vector<std::vector<sim::Pose2>>{{p0}, {p1}, {p2}, blur, {p2}}) {
    EXPECT_EQ(cv::norm(reusing.render(poses, a), fresh.render(poses, b), cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(reusing.stillFramesRendered(), 3u);  // p0, p1, p2; the last p2 reuses despite the blur
  EXPECT_EQ(reusing.stillFramesReused(), 1u);
  // Within the tolerance: the image is reused, and it differs from the exact one by far less than
  // the noise (a few pixels may differ more: a 0.003 px move can tip an edge pixel's choice
  // between blending and supersampling, each as close to the pixel's true area as the other).
  const sim::Pose2 p3{p2.x_m + 1e-9, p2.y_m, p2.yaw_rad + 1e-7};
  EXPECT_LT(reusing.imageMotionBoundPx(p2, p3, 0.05), 0.01);
  EXPECT_GT(reusing.imageMotionBoundPx(p0, p1, 0.05), 0.01);
  reusing.render({p3}, a);
  EXPECT_EQ(reusing.stillFramesReused(), 2u);
  const cv::Mat exact = reusing.renderExact(p3), cached = reusing.renderExact(p2);
  const double rms = cv::norm(exact, cached, cv::NORM_L2) / std::sqrt(static_cast<double>(exact.total() * 3));
  std::cout << "rendered anew vs reused, 0.003 px apart: RMS " << rms << " grey levels, largest "
            << cv::norm(exact, cached, cv::NORM_INF) << std::endl;
  EXPECT_LT(rms, 0.05 * robot.camera.noise_sigma);
}

// The motion bound is an upper bound: projecting world points from two nearby poses moves none
// of them by more than it says.
TEST(SimRendererStillReuse, ImageMotionBoundHoldsForProjectedPoints) {
  const sim::RobotConfig robot = defaultRobot();
  sim::Renderer renderer(robot.camera, defaultWorld(), optionsOf(robot.camera));
  const sim::Pose2 a{0.1, -0.05, 0.7}, b{0.1 + 2e-4, -0.05 - 1e-4, 0.7 + 5e-4};
  const double nearest_m = 0.08;
  const double bound = renderer.imageMotionBoundPx(a, b, nearest_m);
  const sim::CameraModel& camera = renderer.camera();
  const Eigen::Isometry3d ca = sim::cameraInWorld(robot.camera, a).inverse(),
                          cb = sim::cameraInWorld(robot.camera, b).inverse();
  const Eigen::Vector3d centre = sim::cameraInWorld(robot.camera, a).translation();
  double largest = 0;
  int seen = 0;
  for (int i = 0; i < 4000; ++i) {
    // Points at 0.08 .. 2 m in all directions around the camera.
    const double az = 0.0017 * i * 7, el = -0.9 + 1.8 * ((i * 37) % 1000) / 1000.0, r = nearest_m + 0.0005 * i;
    const Eigen::Vector3d p = centre + r * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    Eigen::Vector2d pa, pb;
    if (!camera.project(ca * p, &pa) || !camera.project(cb * p, &pb)) continue;
    if (pa.x() < 0 || pa.y() < 0 || pa.x() > robot.camera.truth.width || pa.y() > robot.camera.truth.height) continue;
    ++seen;
    largest = std::max(largest, (pa - pb).norm());
  }
  EXPECT_GT(seen, 100);
  EXPECT_GT(largest, 0.0);
  EXPECT_LE(largest, bound);
}
