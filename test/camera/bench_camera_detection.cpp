// Detection speed per 640x480 frame, single-threaded: OpenCV's left*.jpg (a 9x6 board in view)
// and natural photos of the same size without a board (opencv-doc). Prints one line per case:
//   <case> <ms per frame> <frames>
// Used by scripts/bench/camera.sh.
#include <glob.h>

#include <chrono>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "autocal/camera/chessboard.h"
#include "autocal/camera/view_selection.h"

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

template <typename F>
double msPerFrame(const std::vector<cv::Mat>& frames, int rounds, F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < rounds; ++r) {
    for (const cv::Mat& m : frames) f(m);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return 1000.0 * s / (rounds * static_cast<double>(frames.size()));
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
  ChessboardDetectorOptions one;
  one.max_boards = 1;
  ChessboardDetectorOptions multi;  // default: up to 4 boards
  int found = 0;
  const double board_one = msPerFrame(with_board, rounds, [&](const cv::Mat& m) {
    found += static_cast<int>(detectChessboards(m, one).size());
  });
  const double board_multi =
      msPerFrame(with_board, rounds, [&](const cv::Mat& m) { detectChessboards(m, multi); });
  const double none_multi = msPerFrame(without, rounds, [&](const cv::Mat& m) {
    found += static_cast<int>(detectChessboards(m, multi).size());
  });
  // The whole per-frame path of a kept view: detect, blur metric, diversity, refinement.
  const double kept = msPerFrame(with_board, rounds, [&](const cv::Mat& m) {
    ViewSelectionOptions sel;
    sel.min_novelty = 0;
    ViewCollector c(multi, sel);
    c.addFrame(m, "frame");
  });
  std::printf("board_in_view_first_board %.2f %zu\n", board_one, with_board.size());
  std::printf("board_in_view_up_to_4_boards %.2f %zu\n", board_multi, with_board.size());
  std::printf("no_board_up_to_4_boards %.2f %zu\n", none_multi, without.size());
  std::printf("board_in_view_kept_view_full_path %.2f %zu\n", kept, with_board.size());
  std::printf("boards_found_check %d\n", found);
  return 0;
}
