// Detection speed per 640x480 frame, single-threaded: OpenCV's left*.jpg (a 9x6 board in view),
// natural photos of the same size without a board (opencv-doc), and frames the simulator renders
// as the robot pivots in front of its boards (7x5; several boards in view, some cut by the
// image's edge). Prints one line per case:
//   <case> <mean ms per frame> <slowest frame ms> <frames> [<boards found>]
// Used by scripts/bench/camera.sh.
#include <glob.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <chrono>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "autocal/camera/chessboard.h"
#include "autocal/camera/view_selection.h"
#include "autocal/sim/config.h"
#include "autocal/sim/renderer.h"
#include "autocal/sim/simulation.h"

using namespace autocal::camera;

namespace {

std::vector<cv::Mat> load(const std::string& pattern) {
  glob_t g;
  std::vector<cv::Mat> out;
  if (::glob(pattern.c_str(), 0, nullptr, &g) == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) {
      cv::Mat img = cv::imread(g.gl_pathv[i], cv::IMREAD_GRAYSCALE);
      if (img.empty()) continue;
      if (img.size() != cv::Size(640, 480))
        cv::resize(img, img, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
      out.push_back(img);
    }
  }
  globfree(&g);
  return out;
}

struct Timing {
  double mean_ms = 0;  ///< mean over frames of each frame's best time over the rounds
  double max_ms = 0;   ///< the slowest frame's best time
};

// Each frame is timed alone, `rounds` times; its best time is kept (the machine is shared, and
// the best time is the one least disturbed by other processes).
template <typename F>
Timing timeFrames(const std::vector<cv::Mat>& frames, int rounds, F&& f) {
  Timing t;
  for (const cv::Mat& m : frames) {
    double best = 1e9;
    for (int r = 0; r < rounds; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      f(m);
      best = std::min(
          best,
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    t.mean_ms += best / static_cast<double>(frames.size());
    t.max_ms = std::max(t.max_ms, best);
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string data = argc > 1 ? argv[1] : "/usr/share/doc/opencv-doc/examples/data";
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 5;
  cv::setNumThreads(1);
  const std::vector<cv::Mat> with_board = load(data + "/left[0-9]*.jpg");
  std::vector<cv::Mat> without;
  for (const char* name :
       {"fruits.jpg", "building.jpg", "home.jpg", "baboon.jpg", "aloeL.jpg", "stuff.jpg"}) {
    for (const cv::Mat& m : load(data + "/" + name)) without.push_back(m);
  }
  if (with_board.empty() || without.empty()) {
    std::fprintf(stderr, "bench_camera_detection: images missing under %s\n", data.c_str());
    return 1;
  }
  const BoardSpec photo_board;  // OpenCV's sample photos: 9x6
  ChessboardDetectorOptions one;
  one.max_boards = 1;
  ChessboardDetectorOptions multi;  // default: up to 4 boards
  int found = 0;
  const Timing board_one = timeFrames(with_board, rounds, [&](const cv::Mat& m) {
    found += static_cast<int>(detectChessboards(m, photo_board, one).size());
  });
  const Timing board_multi =
      timeFrames(with_board, rounds, [&](const cv::Mat& m) { detectChessboards(m, photo_board, multi); });
  const Timing none_multi = timeFrames(without, rounds, [&](const cv::Mat& m) {
    found += static_cast<int>(detectChessboards(m, photo_board, multi).size());
  });
  // The whole per-frame path of a kept view: detect, blur metric, diversity, refinement.
  const Timing kept = timeFrames(with_board, rounds, [&](const cv::Mat& m) {
    ViewSelectionOptions sel;
    sel.min_novelty = 0;
    ViewCollector c(photo_board, multi, sel);
    c.addFrame(m, "frame");
  });
  const auto line = [](const char* name, const Timing& t, size_t n) {
    std::printf("%s %.2f %.2f %zu\n", name, t.mean_ms, t.max_ms, n);
  };
  line("board_in_view_first_board", board_one, with_board.size());
  line("board_in_view_up_to_4_boards", board_multi, with_board.size());
  line("no_board_up_to_4_boards", none_multi, without.size());
  line("board_in_view_kept_view_full_path", kept, with_board.size());
  // The simulator's pivot scene: 36 still frames, pivoting on the left wheel through 180 degrees.
  const std::string sim_dir = std::string(AUTOCAL_SOURCE_DIR) + "/sim/config/";
  const autocal::sim::RobotConfig robot = autocal::sim::loadRobotConfig(sim_dir + "robot_ideal.yaml");
  const autocal::sim::WorldConfig world = autocal::sim::loadWorldConfig(sim_dir + "world.yaml");
  autocal::sim::RenderOptions render;
  render.noise_sigma = robot.camera.noise_sigma;
  autocal::sim::Renderer renderer(robot.camera, world, render);
  std::mt19937_64 rng(1);
  std::vector<cv::Mat> sim_frames;
  for (int i = 0; i < 36; ++i) {
    const autocal::sim::Pose2 pose =
        autocal::sim::pivotPose({}, robot.wheelbase, autocal::sim::Side::kLeft, -1.6 + 3.2 * i / 35.0);
    const cv::Mat bgr = renderer.render({pose}, rng);
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    sim_frames.push_back(gray);
  }
  BoardSpec sim_board;
  sim_board.inner_corners = cv::Size(world.chessboards.front().cols, world.chessboards.front().rows);
  sim_board.square_size_m = world.chessboards.front().square_m;
  struct Variant {
    const char* name;
    bool precheck, adaptive;
  };
  for (const Variant& v : {Variant{"sim_frames_default", true, false}, Variant{"sim_frames_adaptive", true, true},
                           Variant{"sim_frames_no_precheck", false, false},
                           Variant{"sim_frames_no_precheck_adaptive", false, true}}) {
    ChessboardDetectorOptions o = multi;
    o.half_resolution_precheck = v.precheck;
    o.adaptive_threshold = v.adaptive;
    int boards = 0;
    for (const cv::Mat& m : sim_frames) boards += static_cast<int>(detectChessboards(m, sim_board, o).size());
    const Timing timed = timeFrames(sim_frames, rounds, [&](const cv::Mat& m) { detectChessboards(m, sim_board, o); });
    std::printf("%s %.2f %.2f %zu %d\n", v.name, timed.mean_ms, timed.max_ms, sim_frames.size(), boards);
  }
  std::printf("boards_found_check %d\n", found);
  return 0;
}
