// make bench, camera sweep section: the camera stage (camera::SweepRun) on the simulator's core
// over the fleet's robot configs and two board layouts — simulated and wall time of the sweep,
// steps, frames, views, the node's per-frame processing cost on one core — and its accuracy
// against the true lens next to plain cv::calibrateCamera on the same views. Prints Markdown.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <opencv2/calib3d.hpp>
#include <string>
#include <vector>

#include "autocal/camera/camera_config.h"
#include "autocal/camera/sweep_run.h"
#include "autocal/sim/config.h"
#include "support/sweep_in_sim.h"

using namespace autocal;

namespace {

struct Errors {
  double focal_pct, principal_px, k1;
};

Errors errorsOf(double fx, double fy, double cx, double cy, double k1, const CameraIntrinsics& t) {
  return {100 * std::max(std::abs(fx / t.fx - 1), std::abs(fy / t.fy - 1)),
          std::hypot(cx - t.cx, cy - t.cy), k1 - t.distortion_coefficients[0]};
}

double cpuMs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

double g_plain_ms = 0;  ///< CPU time of the last plain fit

Errors plain(const std::vector<std::vector<cv::Point2f>>& views, const test::SweepInSim& r,
             const CameraIntrinsics& truth, const CameraIntrinsics* start) {
  const double t0 = cpuMs();
  std::vector<std::vector<cv::Point3f>> obj(views.size(), r.board.points());
  cv::Mat k = start ? cv::Mat(start->cameraMatrix()) : cv::Mat(), d;
  std::vector<cv::Mat> rv, tv;
  cv::calibrateCamera(obj, views, r.image_size, k, d, rv, tv,
                      start ? cv::CALIB_USE_INTRINSIC_GUESS : 0);
  g_plain_ms = cpuMs() - t0;
  return errorsOf(k.at<double>(0, 0), k.at<double>(1, 1), k.at<double>(0, 2), k.at<double>(1, 2),
                  d.at<double>(0), truth);
}

std::string cell(const Errors& e) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3f %% / %.2f px / %+.4f", e.focal_pct, e.principal_px, e.k1);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";
  struct Case {
    const char* robot;
    const char* world;
  };
  const Case cases[] = {{"robot.yaml", "world.yaml"},
                        {"fleet/robot_wide.yaml", "world.yaml"},
                        {"fleet/robot_narrow.yaml", "world.yaml"},
                        {"fleet/robot_p95.yaml", "world_boards_b.yaml"},
                        {"robot.yaml", "world_boards_b.yaml"}};
  std::printf("### The camera stage's sweep\n\n");
  std::printf(
      "`camera::SweepRun` on the simulator's core (no ROS), one thread: probe, sweep, calibration. "
      "Errors\nagainst the simulator's true lens: the larger of fx, fy [%%] / the principal point "
      "[px] / k1. Plain\nOpenCV = `cv::calibrateCamera`, k1 k2 p1 p2 k3, no outlier "
      "handling.\n\n");
  std::printf(
      "| robot | world | sweep sim s | sweep wall s | steps | frames | kept / sharp views | "
      "frame ms median / max | autocal | plain, own start, sharp views | plain, camera_info "
      "start, sharp views | plain, camera_info start, kept views | fit ms autocal / plain |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    const sim::RobotConfig robot = sim::loadRobotConfig(dir + c.robot);
    const sim::WorldConfig world = sim::loadWorldConfig(dir + c.world);
    camera::CameraCalibrationConfig cam = camera::loadCameraCalibrationConfig(
        std::string(AUTOCAL_SOURCE_DIR) + "/config/camera_calibration.yaml");
    cam.board.inner_corners =
        cv::Size(world.chessboards.front().cols, world.chessboards.front().rows);
    cam.board.square_size_m = world.chessboards.front().square_m;
    cam.detector.half_resolution_precheck = false;
    cam.calibration.initial_camera_matrix = robot.camera.nominal.cameraMatrix();
    camera::SweepRunOptions o;
    o.sweep.camera_hfov_rad =
        2 * std::atan(robot.camera.nominal.width / (2 * robot.camera.nominal.fx));
    camera::SweepRun run(o, cam);
    test::SweepInSimOptions so;
    so.seed = 7;
    const test::SweepInSim r = test::runSweepInSim(robot, world, run, so);
    if (!r.swept || !r.calibration_failure.empty()) {
      std::printf("| %s | %s | failed: %s%s |\n", c.robot, c.world, r.failure.c_str(),
                  r.calibration_failure.c_str());
      continue;
    }
    std::vector<double> ms = r.frame_ms;
    std::sort(ms.begin(), ms.end());
    const CameraIntrinsics& t = robot.camera.truth;
    const CameraIntrinsics& e = r.result.intrinsics;
    std::vector<std::vector<cv::Point2f>> kept;
    for (const auto& v : run.collector().views()) kept.push_back(v.corners);
    const double c0 = cpuMs();
    (void)run.calibrate();
    const double autocal_ms = cpuMs() - c0;
    const Errors own = plain(r.sharp, r, t, nullptr);
    const Errors nominal = plain(r.sharp, r, t, &robot.camera.nominal);
    const double plain_ms = g_plain_ms;
    const Errors kept_nominal = plain(kept, r, t, &robot.camera.nominal);
    std::printf(
        "| %s | %s | %.1f | %.1f | %d | %d | %d / %d | %.1f / %.1f | %s | %s | %s | %s | %.0f / "
        "%.0f |\n",
        c.robot, c.world, r.sim_s, r.wall_s, r.steps, r.frames_rendered, r.views, r.sharp_views,
        ms[ms.size() / 2], ms.back(),
        cell(errorsOf(e.fx, e.fy, e.cx, e.cy, e.distortion_coefficients[0], t)).c_str(),
        cell(own).c_str(), cell(nominal).c_str(), cell(kept_nominal).c_str(), autocal_ms, plain_ms);
    std::fflush(stdout);
  }
  return 0;
}
