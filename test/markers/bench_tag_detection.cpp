// AprilTag detection + pose per 640x480 frame on one core, on the simulator's rendered floor tags
// (default robot and world; robot poses facing the tag strip with 1–6 tags fully in view):
//   ours   markers::TagDetector::detect: undistort with the true lens, libapriltag, IPPE pose
//   plain  libapriltag on the raw (distorted) frame with the same options and its own
//          estimate_tag_pose with the camera_info's K (what apriltag_ros does)
// at quad_decimate 1 and 2. Grey frames in (the BGR->grey conversion is left out of both). Each
// frame is timed `rounds` times and its best time kept (the machine is shared). Also the position
// error of every detected tag against the simulator's truth. Prints one line per variant:
//   <variant> <frames> <median ms> <p90 ms> <p99 ms> <max ms> <tags> <median mm> <p90 mm> <max mm>
// (plain_detect_only: plain libapriltag without the pose; undistort_only: the remap alone).
// Used by scripts/bench/tags.sh.
#include <apriltag/apriltag.h>
#include <apriltag/apriltag_pose.h>
#include <apriltag/tag36h11.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "autocal/markers/tag_detector.h"
#include "autocal/sim/camera_model.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/scene.h"
#include "autocal/wheels/tag_heading.h"

using namespace autocal;

namespace {

struct Frame {
  cv::Mat gray;
  std::vector<std::pair<int, Eigen::Vector3d>> truth;  ///< every tag's centre in the camera frame
};

/// Position of a detected tag centre [m] in the camera frame, by id.
using Positions = std::vector<std::pair<int, Eigen::Vector3d>>;

/// libapriltag as apriltag_ros uses it: detection on the raw frame, pose from K only.
class PlainApriltag {
 public:
  PlainApriltag(const markers::TagDetectorOptions& o, const CameraIntrinsics& k)
      : options_(o), k_(k), family_(tag36h11_create()), detector_(apriltag_detector_create()) {
    apriltag_detector_add_family_bits(detector_, family_, o.max_hamming);
    detector_->quad_decimate = static_cast<float>(o.decimate);
    detector_->quad_sigma = static_cast<float>(o.blur_sigma_px);
    detector_->nthreads = o.threads;
    detector_->refine_edges = o.refine_edges ? 1 : 0;
  }
  ~PlainApriltag() {
    apriltag_detector_destroy(detector_);
    tag36h11_destroy(family_);
  }
  Positions detect(const cv::Mat& gray, bool with_pose = true) const {
    image_u8_t im{gray.cols, gray.rows, static_cast<int32_t>(gray.step), gray.data};
    zarray_t* found = apriltag_detector_detect(detector_, &im);
    Positions out;
    for (int i = 0; i < zarray_size(found); ++i) {
      apriltag_detection_t* det = nullptr;
      zarray_get(found, i, &det);
      if (det->hamming > options_.max_hamming ||
          det->decision_margin < options_.min_decision_margin)
        continue;
      if (!with_pose) {
        out.emplace_back(det->id, Eigen::Vector3d(NAN, NAN, NAN));
        continue;
      }
      apriltag_detection_info_t info{det, options_.tag_size_m, k_.fx, k_.fy, k_.cx, k_.cy};
      apriltag_pose_t pose;
      estimate_tag_pose(&info, &pose);
      out.emplace_back(det->id, Eigen::Vector3d(MATD_EL(pose.t, 0, 0), MATD_EL(pose.t, 1, 0),
                                                MATD_EL(pose.t, 2, 0)));
      // Debian's libapriltag does not export matd_destroy; a matd_t is one calloc (its data is a
      // flexible array member), which is what matd_destroy frees.
      std::free(pose.R);
      std::free(pose.t);
    }
    apriltag_detections_destroy(found);
    return out;
  }

 private:
  markers::TagDetectorOptions options_;
  CameraIntrinsics k_;
  apriltag_family_t* family_;
  apriltag_detector_t* detector_;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double at = p / 100.0 * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

template <typename F>
void measure(const char* name, const std::vector<Frame>& frames, int rounds, F&& detect) {
  std::vector<double> ms, err_mm;
  int tags = 0;
  for (const Frame& f : frames) {
    double best = 1e9;
    Positions found;
    for (int r = 0; r < rounds; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      found = detect(f.gray);
      best = std::min(
          best,
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    ms.push_back(best);
    for (const auto& [id, p] : found) {
      ++tags;
      for (const auto& [tid, tp] : f.truth) {
        if (tid == id && p.allFinite()) err_mm.push_back(1000 * (p - tp).norm());
      }
    }
  }
  std::printf("%s %zu %.2f %.2f %.2f %.2f %d %.1f %.1f %.1f\n", name, frames.size(),
              percentile(ms, 50), percentile(ms, 90), percentile(ms, 99), percentile(ms, 100), tags,
              percentile(err_mm, 50), percentile(err_mm, 90), percentile(err_mm, 100));
}

}  // namespace

int main(int argc, char** argv) {
  const int n_frames = argc > 1 ? std::atoi(argv[1]) : 240;
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 3;
  cv::setNumThreads(1);  // one core: OpenCV's remap and cvtColor would otherwise use a pool
  const std::string dir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";
  const sim::RobotConfig robot = sim::loadRobotConfig(dir + "robot_ideal.yaml");
  const sim::WorldConfig world = sim::loadWorldConfig(dir + "world.yaml");
  sim::RenderOptions ro;
  ro.supersampling = robot.camera.supersampling;
  ro.noise_sigma = robot.camera.noise_sigma;
  sim::Renderer renderer(robot.camera, world, ro);
  const CameraIntrinsics& K = robot.camera.truth;
  const sim::CameraModel lens(K);

  // Poses facing the strip (−x), drawn with a fixed seed; a frame is kept when 1–6 tags are fully
  // in view (10 px from the edge).
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(-1.2, 0.1), uy(-0.1, 0.1), uyaw(-0.6, 0.6);
  std::vector<Frame> frames;
  int histogram[7] = {0};
  for (int attempt = 0; static_cast<int>(frames.size()) < n_frames && attempt < 20 * n_frames;
       ++attempt) {
    const sim::Pose2 pose{ux(rng), uy(rng), M_PI + uyaw(rng)};
    const Eigen::Isometry3d cam_world = sim::cameraInWorld(robot.camera, pose).inverse();
    Frame f;
    int in_view = 0;
    for (const sim::FloorTagConfig& tag : world.floor_tags) {
      f.truth.emplace_back(tag.id, (cam_world * sim::tagInWorld(tag)).translation());
      bool inside = true;
      for (const Eigen::Vector3d& c : sim::tagCorners(tag)) {
        Eigen::Vector2d px;
        if (!lens.project(cam_world * c, &px) || px.x() < 10 || px.y() < 10 ||
            px.x() > K.width - 10 || px.y() > K.height - 10)
          inside = false;
      }
      in_view += inside;
    }
    if (in_view < 1 || in_view > 6) continue;
    ++histogram[in_view];
    cv::cvtColor(renderer.render({pose}, rng), f.gray, cv::COLOR_BGR2GRAY);
    frames.push_back(std::move(f));
  }
  std::printf("tags_in_view");
  for (int i = 1; i <= 6; ++i) std::printf(" %d", histogram[i]);
  std::printf("\n");

  for (double decimate : {1.0, 2.0}) {
    markers::TagDetectorOptions o;  // the defaults, one thread
    o.decimate = decimate;
    o.threads = 1;
    const markers::TagDetector ours(o, K);
    const PlainApriltag plain(o, K);
    const std::string d = decimate == 1.0 ? "_d1" : "_d2";
    measure(("ours" + d).c_str(), frames, rounds, [&](const cv::Mat& gray) {
      Positions out;
      for (const markers::TagDetection& t : ours.detect(gray)) {
        out.emplace_back(
            t.id, Eigen::Vector3d(t.translation_m[0], t.translation_m[1], t.translation_m[2]));
      }
      return out;
    });
    // As the wheel stage runs it: only the rows that can show floor within 0.6 m + a tag
    // (WheelRunOptions::crop_to_floor), with the nominal mount.
    markers::TagDetectorOptions of = o;
    of.min_row_px = std::max(0, wheels::floorRowLimitPx(wheels::CameraMount(), K.fy, K.cy, K.height,
                                                        0.6 + o.tag_size_m) -
                                    12);
    const markers::TagDetector floor_only(of, K);
    measure(("ours_floor" + d).c_str(), frames, rounds, [&](const cv::Mat& gray) {
      Positions out;
      for (const markers::TagDetection& t : floor_only.detect(gray)) {
        out.emplace_back(
            t.id, Eigen::Vector3d(t.translation_m[0], t.translation_m[1], t.translation_m[2]));
      }
      return out;
    });
    if (decimate == 1.0) std::printf("floor_row %d\n", of.min_row_px);
    measure(("plain" + d).c_str(), frames, rounds,
            [&](const cv::Mat& gray) { return plain.detect(gray); });
    measure(("plain_detect_only" + d).c_str(), frames, rounds,
            [&](const cv::Mat& gray) { return plain.detect(gray, false); });
    // The undistortion alone (cv::remap with precomputed maps).
    measure(("undistort_only" + d).c_str(), frames, rounds, [&](const cv::Mat& gray) {
      ours.undistorter().undistort(gray);
      return Positions{};
    });
  }
  return 0;
}
