// Accuracy on real photos: OpenCV's sample images (Debian opencv-doc, left*.jpg, 9x6 inner
// corners, 25 mm squares) and OpenCV's own reference result for them (left_intrinsics.yml).
#include <glob.h>
#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "autocal/camera/calibration.h"
#include "autocal/camera/chessboard.h"
#include "autocal/camera/view_selection.h"
#include "autocal/parallel.h"

using namespace autocal::camera;

namespace {

const char* kDataDir = "/usr/share/doc/opencv-doc/examples/data";
constexpr double kReferenceFx = 535.9157;  // left_intrinsics.yml

std::vector<std::string> photos() {
  glob_t g;
  std::vector<std::string> out;
  if (::glob((std::string(kDataDir) + "/left[0-9]*.jpg").c_str(), 0, nullptr, &g) == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) out.push_back(g.gl_pathv[i]);
  }
  globfree(&g);
  return out;
}

struct Photos {
  std::vector<std::vector<cv::Point2f>> autocal_corners;  // autocal's detection + refinement
  std::vector<std::vector<cv::Point2f>> sample_corners;   // OpenCV's sample: cornerSubPix 11x11
  cv::Size size;
};

const Photos& loadPhotos() {
  static Photos p = [] {
    Photos p;
    ChessboardDetectorOptions det;
    ViewSelectionOptions sel;
    sel.min_novelty = 0.0;  // every photo: the figures below are over all 13
    ViewCollector collector(BoardSpec(), det, sel);
    for (const std::string& f : photos()) {
      const cv::Mat img = cv::imread(f, cv::IMREAD_GRAYSCALE);
      EXPECT_FALSE(img.empty()) << f;
      const FrameResult r = collector.addFrame(img, f);
      EXPECT_EQ(r.boards_found, 1) << f;
      EXPECT_TRUE(r.any_kept()) << f << ": " << (r.decisions.empty() ? "" : r.decisions[0].reason);
      std::vector<cv::Point2f> c;
      cv::findChessboardCorners(img, BoardSpec().inner_corners, c,
                                cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      cv::cornerSubPix(img, c, cv::Size(11, 11), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.1));
      p.sample_corners.push_back(c);
    }
    for (const auto& v : collector.views()) p.autocal_corners.push_back(v.corners);
    p.size = collector.imageSize();
    return p;
  }();
  return p;
}

}  // namespace

TEST(CameraRealPhotos, FocalLengthWithinTwoPercentOfOpenCvReference) {
  ASSERT_EQ(photos().size(), 13u) << "opencv-doc's left*.jpg are missing (make deps)";
  const Photos& p = loadPhotos();
  ASSERT_EQ(p.autocal_corners.size(), 13u);
  const CalibrationResult r =
      calibrate(p.autocal_corners, p.size, BoardSpec(), CalibrationOptions());
  std::printf(
      "autocal: fx %.2f fy %.2f cx %.2f cy %.2f rms %.3f px, terms: %s, %zu views, %d corners "
      "dropped\n",
      r.intrinsics.fx, r.intrinsics.fy, r.intrinsics.cx, r.intrinsics.cy, r.rms_px,
      r.fitted_terms.c_str(), r.used_views.size(), r.dropped_corners);
  EXPECT_NEAR(r.intrinsics.fx, kReferenceFx, 0.02 * kReferenceFx);
  EXPECT_NEAR(r.intrinsics.fy, kReferenceFx, 0.02 * kReferenceFx);
  EXPECT_TRUE(checkQuality(r, QualityGateOptions()).empty());
  ASSERT_EQ(r.std_devs.size(), 9u);
  EXPECT_GT(r.std_devs[0], 0.0);
  EXPECT_LT(r.std_devs[0], 5.0);
}

TEST(CameraRealPhotos, HeldOutErrorNoWorseThanPlainOpenCv) {
  const Photos& p = loadPhotos();
  ASSERT_EQ(p.autocal_corners.size(), 13u);
  const CalibrationOptions options;
  const auto t0 = std::chrono::steady_clock::now();
  const HoldoutEvaluation ours =
      leaveOneOut(p.autocal_corners, p.size, BoardSpec(), options, HoldoutMethod::kAutocal);
  const auto t1 = std::chrono::steady_clock::now();
  const HoldoutEvaluation plain_same =
      leaveOneOut(p.autocal_corners, p.size, BoardSpec(), options, HoldoutMethod::kPlainOpenCv);
  const HoldoutEvaluation plain_sample =
      leaveOneOut(p.sample_corners, p.size, BoardSpec(), options, HoldoutMethod::kPlainOpenCv);
  std::printf(
      "leave-one-out held-out RMS [px]: autocal %.3f (fx spread %.2f px, %.1f s) | "
      "plain calibrateCamera on autocal's corners %.3f (spread %.2f) | "
      "plain calibrateCamera on OpenCV-sample corners %.3f (spread %.2f)\n",
      ours.mean_rms_px, ours.fx_spread_px, std::chrono::duration<double>(t1 - t0).count(),
      plain_same.mean_rms_px, plain_same.fx_spread_px, plain_sample.mean_rms_px,
      plain_sample.fx_spread_px);
  EXPECT_LE(ours.mean_rms_px, plain_same.mean_rms_px * 1.0001);
  EXPECT_LE(ours.mean_rms_px, plain_sample.mean_rms_px);
}

TEST(CameraRealPhotos, TwoRealBoardsInOneFrameAreSeparated) {
  // Two photos side by side: one 1280x480 frame with two boards of the same size.
  const auto files = photos();
  ASSERT_GE(files.size(), 3u);
  const cv::Mat a = cv::imread(files[0], cv::IMREAD_GRAYSCALE);
  const cv::Mat b = cv::imread(files[2], cv::IMREAD_GRAYSCALE);
  cv::Mat frame;
  cv::hconcat(a, b, frame);
  ChessboardDetectorOptions det;
  std::vector<BoardDetection> boards = detectChessboards(frame, BoardSpec(), det);
  ASSERT_EQ(boards.size(), 2u);
  int left = 0, right = 0;
  for (BoardDetection& board : boards) {
    refineCorners(frame, BoardSpec(), board, det);
    int in_left = 0;
    for (const auto& p : board.corners) in_left += p.x < a.cols;
    // All 54 corners on one side: never a mix of the two boards.
    EXPECT_TRUE(in_left == 0 || in_left == 54) << in_left << " corners on the left";
    (in_left ? left : right) += 1;
  }
  EXPECT_EQ(left, 1);
  EXPECT_EQ(right, 1);
}

TEST(CameraRealPhotos, FramesDetectedOnThreadsAreKeptAsOneAfterAnother) {
  // The offline tool detects a batch of frames on several threads and adds them in order: the
  // views kept must be those of addFrame one frame after another. With the default novelty,
  // left12.jpg is refused as too similar to left08.jpg, so the order matters.
  const auto files = photos();
  ASSERT_GE(files.size(), 13u);
  std::vector<cv::Mat> images;
  for (const std::string& f : files) images.push_back(cv::imread(f, cv::IMREAD_GRAYSCALE));
  for (const bool keep_sharp : {true, false}) {
    ViewSelectionOptions sel;
    sel.keep_sharp_views = keep_sharp;
    ViewCollector one{BoardSpec(), ChessboardDetectorOptions(), sel};
    ViewCollector batch{BoardSpec(), ChessboardDetectorOptions(), sel};
    std::vector<FrameResult> sequential;
    for (size_t i = 0; i < images.size(); ++i)
      sequential.push_back(one.addFrame(images[i], files[i]));
    std::vector<DetectedFrame> detected(images.size());
    autocal::forEachIndex(images.size(), 2,
                          [&](size_t i) { detected[i] = batch.detect(images[i], files[i]); });
    int refused = 0;
    for (size_t i = 0; i < images.size(); ++i) {
      const FrameResult r = batch.add(std::move(detected[i]), files[i]);
      ASSERT_EQ(r.decisions.size(), sequential[i].decisions.size()) << files[i];
      for (size_t b = 0; b < r.decisions.size(); ++b) {
        const ViewDecision &d = r.decisions[b], &s = sequential[i].decisions[b];
        EXPECT_EQ(d.kept, s.kept) << files[i];
        EXPECT_EQ(d.sharp, s.sharp) << files[i];
        EXPECT_EQ(d.reason, s.reason) << files[i];
        EXPECT_EQ(d.corners, s.corners) << files[i];
        refused += !d.kept;
      }
    }
    EXPECT_GE(refused, 1) << "no view refused: the order was never tested";
    const auto same_views = [](const std::vector<CalibrationView>& a,
                               const std::vector<CalibrationView>& b) {
      if (a.size() != b.size()) return false;
      for (size_t i = 0; i < a.size(); ++i)
        if (a[i].corners != b[i].corners || a[i].source != b[i].source ||
            a[i].frame_index != b[i].frame_index || a[i].patch.origin != b[i].patch.origin ||
            a[i].patch.gray.size() != b[i].patch.gray.size() ||
            (!a[i].patch.gray.empty() && cv::norm(a[i].patch.gray, b[i].patch.gray) != 0))
          return false;
      return true;
    };
    EXPECT_TRUE(same_views(batch.views(), one.views()));
    EXPECT_TRUE(same_views(batch.calibrationViews(), one.calibrationViews()));
  }
}
