// report::RunRecorder and the report files: the recorder follows the status protocol (DESIGN.md
// "The calibration run"), the believed path integrates the encoders, the files are written and
// read back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "autocal/errors.h"
#include "autocal/io/yaml_reader.h"
#include "autocal/report/camera_view.h"
#include "autocal/report/run_report.h"

using namespace autocal;
using namespace autocal::report;
namespace fs = std::filesystem;

namespace {

StatusUpdate status(double t, const std::string& phase, StatusUpdate::State state,
                    const std::string& text,
                    std::vector<std::pair<std::string, double>> figures = {}) {
  StatusUpdate u;
  u.stamp_s = t;
  u.phase = phase;
  u.state = state;
  u.text = text;
  if (state == StatusUpdate::State::kFailed) u.failure_reason = text;
  // As StatusPublisher::wrote: a DONE "wrote <file>" carries the file in its own field.
  if (state == StatusUpdate::State::kDone && text.rfind("wrote ", 0) == 0) u.file = text.substr(6);
  u.figures = std::move(figures);
  return u;
}

const auto kRunning = StatusUpdate::State::kRunning;
const auto kDone = StatusUpdate::State::kDone;
const auto kFailed = StatusUpdate::State::kFailed;

}  // namespace

TEST(RunRecorder, EndsWhenEveryStageIsDone) {
  RunRecorder r("autobot", {"camera", "wheels"});
  EXPECT_EQ(r.currentStage(), "camera");
  r.addStatus(status(1, "sim", kRunning, "sim"));  // not a stage of the run
  r.addStatus(status(2, "camera/collect", kRunning, "collecting"));
  r.addStatus(status(3, "wheels/wait", kRunning, "waiting for the camera stage"));
  EXPECT_FALSE(r.ended());
  r.addStatus(status(40, "camera/write", kDone, "wrote /x/camera_intrinsic/autobot.yaml",
                     {{"rms_px", 0.08}}));
  EXPECT_EQ(r.currentStage(), "wheels");
  for (int i = 1; i <= 3; ++i) {
    r.addStatus(status(50 + i, "wheels/iterate", kRunning, "it",
                       {{"iteration", i}, {"k", 1.0 + 0.01 * i}, {"trim", 0.005 * i}}));
    r.addStatus(status(50.5 + i, "wheels/iterate", kRunning, "it",
                       {{"iteration", i}, {"k", 1.0 + 0.01 * i}, {"trim", 0.005 * i}}));
  }
  r.addStatus(status(90, "wheels/write", kDone, "wrote /x/kinematics/autobot.yaml",
                     {{"drives", 3}, {"k", 1.031}, {"trim", 0.0155}}));
  ASSERT_TRUE(r.ended());
  const RunRecord& rec = r.record();
  EXPECT_TRUE(rec.succeeded());
  EXPECT_EQ(rec.failure(), "");
  EXPECT_EQ(rec.stage("camera")->file, "/x/camera_intrinsic/autobot.yaml");
  EXPECT_DOUBLE_EQ(rec.stage("camera")->start_s, 2);
  EXPECT_DOUBLE_EQ(rec.stage("wheels")->start_s, 51);  // not its wait for the camera stage
  EXPECT_DOUBLE_EQ(rec.stage("camera")->end_s, 40);
  ASSERT_EQ(rec.wheel_iterations.size(), 3u);              // one per drive, not per status
  EXPECT_DOUBLE_EQ(rec.wheel_iterations.back().k, 1.031);  // the DONE's final k
  EXPECT_EQ(rec.stage("wheels")->file, "/x/kinematics/autobot.yaml");
}

TEST(RunRecorder, OneFailedStageEndsTheRunAndLaterStatusesAreIgnored) {
  RunRecorder r("autobot", {"camera", "wheels", "odometry"});
  r.addStatus(status(2, "camera/collect", kRunning, "collecting"));
  r.addStatus(status(9, "camera/collect", kFailed, "no board in view over a full turn"));
  ASSERT_TRUE(r.ended());
  r.addStatus(status(10, "camera/collect", kRunning, "late"));
  EXPECT_FALSE(r.record().succeeded());
  EXPECT_EQ(r.record().failure(), "camera: no board in view over a full turn");
  EXPECT_EQ(r.record().stage("odometry")->state, StageState::kPending);
}

TEST(RunRecorder, AStageThatOnlyWaitedIsNotStartedInTheSummaryAndGates) {
  RunRecorder r("autobot", {"camera", "wheels", "odometry"});
  r.addStatus(status(1, "wheels/wait", kRunning, "waiting for the camera stage"));
  r.addStatus(status(2, "camera/collect", kRunning, "collecting"));
  r.addStatus(status(9, "camera/collect", kFailed, "no board in view over a full turn"));
  ASSERT_TRUE(r.ended());
  EXPECT_EQ(r.record().stage("camera")->stateText(), "failed");
  EXPECT_EQ(r.record().stage("wheels")->stateText(), "not started");
  EXPECT_EQ(r.record().stage("odometry")->stateText(), "not started");
  const std::string yaml = summaryYaml(r.record(), ViewsAudit(), ReportOptions(), "t");
  EXPECT_NE(yaml.find("  wheels:\n    state: not started\n"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("state: running"), std::string::npos) << yaml;
  for (const Gate& g : evaluateGates(r.record())) {
    if (g.name == "wheels stage") {
      EXPECT_EQ(g.detail, "not started");
    }
  }
}

TEST(RunRecorder, DeadStageAndInterruption) {
  RunRecorder r("autobot", {"wheels"});
  r.addStatus(status(2, "wheels/iterate", kRunning, "it"));
  r.markStageDead("wheels", "/autobot/wheel_calibration_node died");
  EXPECT_TRUE(r.ended());
  EXPECT_EQ(r.record().failure(), "wheels: /autobot/wheel_calibration_node died");
  RunRecorder s("autobot", {"camera"});
  s.markInterrupted("interrupted");
  EXPECT_TRUE(s.ended());
  EXPECT_EQ(s.record().failure(), "interrupted");
  EXPECT_THROW(RunRecorder("a", {}), ConfigError);
  EXPECT_THROW(RunRecorder("a", {"camera", "camera"}), ConfigError);
  EXPECT_THROW(RunRecorder("a", {"camera/x"}), ConfigError);
}

TEST(StageHealth, OkWhileRunningOrDoneErrorWhenFailedWarnWhenSilent) {
  using Level = StageHealth::Level;
  RunRecorder r("autobot", {"camera", "wheels"});
  const auto health = [&](const std::string& stage, double silent_s) {
    return stageHealth(*r.record().stage(stage), r.currentStage() == stage, silent_s, 10.0);
  };
  EXPECT_EQ(health("camera", 1).level, Level::kOk);
  EXPECT_EQ(health("camera", 1).message, "waiting for the stage to start");
  EXPECT_EQ(health("camera", 11).level, Level::kWarn) << "the stage the run waits on never spoke";
  EXPECT_EQ(health("wheels", 500).level, Level::kOk) << "a later stage is not waited on yet";
  EXPECT_EQ(health("wheels", 500).message, "pending");

  r.addStatus(status(2, "camera/collect", kRunning, "3 views"));
  StageHealth h = health("camera", 0.5);
  EXPECT_EQ(h.level, Level::kOk);
  EXPECT_NE(h.message.find("camera/collect"), std::string::npos) << h.message;
  EXPECT_NE(h.message.find("3 views"), std::string::npos) << h.message;
  h = health("camera", 12);
  EXPECT_EQ(h.level, Level::kWarn);
  EXPECT_EQ(h.message.rfind("silent for 12 s", 0), 0u) << h.message;
  EXPECT_EQ(stageHealth(*r.record().stage("camera"), true, 1e6, 0).level, Level::kOk)
      << "warn_after_s 0: never WARN";

  r.addStatus(status(40, "camera/write", kDone, "wrote /x/c.yaml"));
  EXPECT_EQ(health("camera", 100).level, Level::kOk) << "done is not silent";
  EXPECT_EQ(health("camera", 100).message, "done: wrote /x/c.yaml");
  r.addStatus(status(41, "wheels/iterate", kFailed, "the tags went out of view"));
  h = health("wheels", 0);
  EXPECT_EQ(h.level, Level::kError);
  EXPECT_EQ(h.message, "failed: the tags went out of view");
}

TEST(RunRecorder, KeepsWhatTheLastReportSaysOfAStageWithoutStatus) {
  RunRecorder r("autobot", {"camera", "wheels"});
  r.addStatus(status(2, "wheels/iterate", kFailed, "lost"));
  r.keepFromLastRun("camera", "/x/c.yaml", {{"fx", 318}});
  r.keepFromLastRun("wheels", "/x/k.yaml", {});  // failed in this run: stays failed
  EXPECT_EQ(r.record().stage("camera")->state, StageState::kDone);
  EXPECT_EQ(r.record().stage("camera")->file, "/x/c.yaml");
  EXPECT_EQ(r.record().stage("wheels")->state, StageState::kFailed);
}

TEST(Report, PreviousStageReadsTheSummaryBack) {
  const fs::path dir = fs::temp_directory_path() / "autocal_test_previous_stage";
  fs::remove_all(dir);
  RunRecorder r("autobot", {"camera", "wheels"});
  r.addStatus(status(1, "camera/write", kDone, "wrote /x/c.yaml", {{"fx", 318.5}, {"k1", -0.27}}));
  r.addStatus(status(2, "wheels/iterate", kFailed, "lost"));
  const ReportFiles f = writeReport(dir.string(), r.record(), "", ReportOptions());
  const PreviousStage camera = previousStage(f.summary_yaml, "camera");
  EXPECT_TRUE(camera.done);
  EXPECT_EQ(camera.file, "/x/c.yaml");
  ASSERT_EQ(camera.figures.size(), 2u);
  EXPECT_EQ(camera.figures[1].first, "k1");
  EXPECT_DOUBLE_EQ(camera.figures[1].second, -0.27);
  EXPECT_FALSE(previousStage(f.summary_yaml, "wheels").done);
  EXPECT_FALSE(previousStage(f.summary_yaml, "odometry").done);
  EXPECT_FALSE(previousStage((dir / "none.yaml").string(), "camera").done);
  fs::remove_all(dir);
}

TEST(BelievedPath, IntegratesTheEncoders) {
  RunRecorder r("autobot", {"wheels"});
  const int tpr = 135;
  const double radius = 0.0318, baseline = 0.1;
  // 1 m straight ahead, then a quarter turn in place to the left, then 0.5 m.
  const int straight = static_cast<int>(std::lround(1.0 / (2 * M_PI * radius) * tpr));
  const int quarter =
      static_cast<int>(std::lround(M_PI / 4 * baseline / (2 * M_PI * radius) * tpr));
  int left = 0, right = 0;
  double t = 0;
  for (int i = 0; i <= straight; ++i) r.addEncoders(t += 0.1, left = i, right = i, tpr);
  for (int i = 1; i <= quarter; ++i) r.addEncoders(t += 0.1, left - i, right + i, tpr);
  left -= quarter, right += quarter;
  const int half = straight / 2;
  for (int i = 1; i <= half; ++i) r.addEncoders(t += 0.1, left + i, right + i, tpr);
  const std::vector<PathPoint> path = believedPath(r.record(), radius, baseline);
  ASSERT_FALSE(path.empty());
  const double tick = 2 * M_PI * radius / tpr;
  EXPECT_NEAR(path.back().pose.x_m, 1.0, 2 * tick);
  EXPECT_NEAR(path.back().pose.y_m, 0.5, 3 * tick);
  EXPECT_NEAR(path.back().pose.yaw_rad, M_PI / 2, 2 * tick / baseline);
  // Readings closer than 50 ms are not kept.
  RunRecorder q("autobot", {"wheels"});
  q.addEncoders(1.00, 0, 0, tpr);
  q.addEncoders(1.01, 1, 1, tpr);
  q.addEncoders(1.06, 2, 2, tpr);
  EXPECT_EQ(q.record().encoders.size(), 2u);
}

// Drives forward and back along x, as the wheel stage does over the tags, at 0.25 m/s, the two
// encoders published as separate readings at 30 Hz: with the left one first at the same stamp
// (the simulator, a driver reading both at once), or 7 ms apart (two drivers). The believed path
// stays on the line: paired as they arrived, the lagging wheel bent every drive to the same side
// (about 3 cm of drift per 0.5 m drive).
TEST(RunRecorder, BelievedPathOfDrivesForwardAndBackStaysOnTheLine) {
  const double radius = 0.0318, baseline = 0.1;
  const int tpr = 135;
  const double rad_per_tick = 2 * M_PI / tpr;
  for (const double right_delay_s : {0.0, 0.007}) {
    RunRecorder r("autobot", {"wheels"});
    // Both wheels turn alike (the truth is the x axis): 2 s each way, 10 drives.
    const double speed_rad_s = 0.25 / radius;
    const auto ticksAt = [&](double t) {
      const int drive = static_cast<int>(t / 2.0);
      const double into = t - 2.0 * drive;
      const double rad = speed_rad_s * (drive % 2 == 0 ? into : 2.0 - into);
      return static_cast<std::int32_t>(std::floor(rad / rad_per_tick));
    };
    for (int i = 1; i <= 600; ++i) {
      const double t = i / 30.0;
      r.addEncoderReading(0, t, ticksAt(t), tpr);
      r.addEncoderReading(1, t + right_delay_s, ticksAt(t + right_delay_s), tpr);
    }
    const std::vector<PathPoint> path = believedPath(r.record(), radius, baseline);
    ASSERT_GT(path.size(), 250u);
    double worst_y = 0, worst_yaw = 0;
    for (const PathPoint& p : path) {
      worst_y = std::max(worst_y, std::abs(p.pose.y_m));
      worst_yaw = std::max(worst_yaw, std::abs(p.pose.yaw_rad));
    }
    // One tick of one wheel is 1.5 mm and 0.015 rad of heading: at most two.
    EXPECT_LT(worst_y, 0.005) << "right " << right_delay_s << " s after the left";
    EXPECT_LT(worst_yaw, 0.03) << "right " << right_delay_s << " s after the left";
  }
}

TEST(EncoderPairer, PairsAtOneInstantInterpolatingTheOtherWheelNeverExtrapolating) {
  EncoderPairer p;
  EXPECT_TRUE(p.add(0, 1.0, 10).empty());  // no right reading yet
  auto out = p.add(1, 1.0, 20);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].left_ticks, 10);
  EXPECT_DOUBLE_EQ(out[0].right_ticks, 20);
  EXPECT_TRUE(p.add(0, 2.0, 30).empty());  // the right count at 2.0 is not known yet
  out = p.add(1, 3.0, 40);  // pairs 2.0 (right interpolated), not 3.0 (no left reading after it)
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].stamp_s, 2.0);
  EXPECT_DOUBLE_EQ(out[0].left_ticks, 30);
  EXPECT_DOUBLE_EQ(out[0].right_ticks, 30);
  EXPECT_TRUE(p.add(0, 1.5, 99).empty());  // older than the left wheel's latest: ignored
  out = p.add(0, 3.0, 50);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].left_ticks, 50);
  EXPECT_DOUBLE_EQ(out[0].right_ticks, 40);
  // 32-bit counts wrap around.
  EncoderPairer w;
  w.add(0, 0.0, std::numeric_limits<std::int32_t>::max());
  w.add(1, 0.0, 0);
  w.add(1, 1.0, 0);
  out = w.add(0, 1.0, std::numeric_limits<std::int32_t>::min());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(
      out[0].left_ticks - static_cast<double>(std::numeric_limits<std::int32_t>::max()), 1);
}

TEST(Report, WritesTheSheetAndTheSummary) {
  const fs::path dir = fs::temp_directory_path() / "autocal_test_run_report";
  fs::remove_all(dir);
  fs::create_directories(dir / "views");
  // An audit with two views whose corners cover two cells.
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  ASSERT_TRUE(cv::imwrite((dir / "views" / "view_000.png").string(), img));
  {
    std::ofstream f(dir / "views" / "views.yaml");
    f << "board: {inner_corners: 7x5, square_size_m: 0.031}\nimage: {width: 640, height: 480}\n"
         "rms_px: 0.1\nviews:\n  - image: view_000.png\n    rms_px: 0.09\n"
         "    corners: [[10, 10], [20, 12]]\n  - image: view_001.png\n    rms_px: 0.11\n"
         "    corners: [[630, 470]]\n";
  }
  const ViewsAudit audit = loadViewsAudit((dir / "views" / "views.yaml").string());
  ASSERT_EQ(audit.views.size(), 2u);
  EXPECT_DOUBLE_EQ(cornerCoverage(audit), 2.0 / 48);

  RunRecorder r("autobot", {"camera", "wheels"});
  r.addStatus(status(1, "camera/write", kDone, "wrote c.yaml", {{"rms_px", 0.1}}));
  r.addStatus(status(2, "wheels/iterate", kRunning, "it", {{"iteration", 1}, {"k", 1.02}}));
  r.addStatus(status(3, "wheels/iterate", kFailed, "the floor tags were lost"));
  for (int i = 0; i < 20; ++i) r.addEncoders(i, 3 * i, 3 * i, 135);
  ReportOptions o;
  const ReportFiles files =
      writeReport((dir / "out").string(), r.record(), (dir / "views" / "views.yaml").string(), o);
  const cv::Mat sheet = cv::imread(files.sheet_png);
  EXPECT_EQ(sheet.cols, 1600);
  EXPECT_EQ(sheet.rows, 1040);
  YamlMap summary = YamlMap::loadFile(files.summary_yaml);
  EXPECT_EQ(summary.required<std::string>("result"), "failed");
  EXPECT_EQ(summary.required<std::string>("failure"), "wheels: the floor tags were lost");
  EXPECT_EQ(summary.map("stages").map("camera").required<std::string>("state"), "done");
  EXPECT_EQ(summary.map("camera_views").required<int>("count"), 2);
  EXPECT_FALSE(summary.required<bool>("gates_passed"));
  // One gate per stage, each the stage's own verdict: the camera's DONE with the figures its gate
  // judged (its coverage of 2 of 48 cells is not the report's to judge), the wheels' FAILED.
  const std::vector<Gate> gates = evaluateGates(r.record());
  ASSERT_EQ(gates.size(), 2u);
  EXPECT_TRUE(gates[0].passed);
  EXPECT_EQ(gates[0].detail, "done, RMS 0.1 px");
  EXPECT_FALSE(gates[1].passed);
  EXPECT_EQ(gates[1].detail, "the floor tags were lost");
  EXPECT_THROW(loadViewsAudit((dir / "none.yaml").string()), IoError);
  fs::remove_all(dir);
}

TEST(TruePath, InTheBelievedPathsFrameFromTheFirstEncoderReading) {
  RunRecorder r("bot", {"wheels"});
  // The simulator's robot at (1, 2) facing +y, then driving 1 m along +y (its forward).
  r.addTruePose(0.0, {1.0, 2.0, M_PI / 2});
  r.addTruePose(0.5, {1.0, 2.0, M_PI / 2});
  for (int i = 1; i <= 10; ++i) r.addTruePose(1.0 + 0.1 * i, {1.0, 2.0 + 0.1 * i, M_PI / 2});
  r.addTruePose(2.02, {5.0, 5.0, 0.0});       // within min_interval_s of the last: dropped
  EXPECT_TRUE(truePath(r.record()).empty());  // no encoder reading yet: no start
  r.addEncoders(0.5, 0, 0, 135);
  const std::vector<PathPoint> path = truePath(r.record());
  ASSERT_EQ(path.size(), 11u);
  EXPECT_DOUBLE_EQ(path.front().t_s, 0.5);
  EXPECT_NEAR(path.back().pose.x_m, 1.0, 1e-12);  // forward
  EXPECT_NEAR(path.back().pose.y_m, 0.0, 1e-12);
  EXPECT_NEAR(path.back().pose.yaw_rad, 0.0, 1e-12);
}

// The audit's projection uncertainty is read and drawn as a map beside the coverage: a 2x2 grid,
// its upper cells certain (green), its lower ones not (red); an audit without one draws none.
TEST(Report, ShowsTheProjectionUncertaintyMap) {
  const fs::path dir = fs::temp_directory_path() / "autocal_test_run_report_uncertainty";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string head = "image: {width: 640, height: 480}\nrms_px: 0.1\n";
  {
    std::ofstream f(dir / "with.yaml");
    f << head
      << "projection_uncertainty:\n  grid: [2, 2]\n  corner_noise_px: 0.1\n  rms_px: 1\n"
         "  worst_px: 2\n  lower_half_worst_px: 2\n  sigma_px: [0, 0.05, 1.5, 2]\nviews: []\n";
    std::ofstream(dir / "without.yaml") << head << "views: []\n";
    std::ofstream(dir / "short.yaml")
        << head << "projection_uncertainty:\n  grid: [2, 2]\n  worst_px: 2\n"
        << "  lower_half_worst_px: 2\n  sigma_px: [0, 1]\n";
  }
  const ViewsAudit audit = loadViewsAudit((dir / "with.yaml").string());
  ASSERT_EQ(audit.uncertainty_px.size(), 4u);
  EXPECT_EQ(audit.uncertainty_cols, 2);
  EXPECT_DOUBLE_EQ(audit.uncertainty_lower_half_worst_px, 2);
  EXPECT_TRUE(loadViewsAudit((dir / "without.yaml").string()).uncertainty_px.empty());
  EXPECT_THROW(loadViewsAudit((dir / "short.yaml").string()), ConfigError);
  RunRecorder r("bot", {"camera"});
  r.addStatus(status(1, "camera/write", kDone, "wrote c.yaml", {{"rms_px", 0.1}}));
  auto count = [](const cv::Mat& sheet, cv::Rect area, cv::Scalar lo, cv::Scalar hi) {
    cv::Mat mask;
    cv::inRange(sheet(area), lo, hi, mask);
    return cv::countNonZero(mask);
  };
  const cv::Rect upper(1310, 95, 270, 100), lower(1310, 200, 270, 95);
  const cv::Scalar green_lo(0, 190, 0), green_hi(10, 215, 30), red_lo(0, 0, 220),
      red_hi(10, 10, 240);
  const cv::Mat with = cv::imread(
      writeReport((dir / "a").string(), r.record(), (dir / "with.yaml").string(), ReportOptions())
          .sheet_png);
  EXPECT_GT(count(with, upper, green_lo, green_hi), 20000);
  EXPECT_GT(count(with, lower, red_lo, red_hi), 20000);
  EXPECT_EQ(count(with, upper, red_lo, red_hi), 0);
  const cv::Mat without = cv::imread(writeReport((dir / "b").string(), r.record(),
                                                 (dir / "without.yaml").string(), ReportOptions())
                                         .sheet_png);
  EXPECT_EQ(count(without, lower, red_lo, red_hi), 0);
  fs::remove_all(dir);
}

TEST(Report, ShowsTheGroundViewOfTheExtrinsicsWhenGiven) {
  const fs::path dir = fs::temp_directory_path() / "autocal_test_run_report_ground";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const cv::Vec3b magenta(200, 0, 200);
  ASSERT_TRUE(cv::imwrite((dir / "bot_ground.png").string(),
                          cv::Mat(480, 640, CV_8UC3, cv::Scalar(200, 0, 200))));
  RunRecorder r("bot", {"wheels"});
  r.addStatus(status(1, "wheels/write", kDone, "wrote k.yaml", {{"extrinsics_written", 1}}));
  auto magentaPixels = [](const cv::Mat& sheet) {
    cv::Mat mask;
    cv::inRange(sheet, cv::Scalar(190, 0, 190), cv::Scalar(210, 10, 210), mask);
    return cv::countNonZero(mask);
  };
  const cv::Mat with = cv::imread(writeReport((dir / "a").string(), r.record(), "", ReportOptions(),
                                              (dir / "bot_ground.png").string())
                                      .sheet_png);
  // The view, scaled into its panel whole (640 x 480 into at most 308 x 298).
  EXPECT_NEAR(magentaPixels(with), 308 * 231, 308 * 4);
  EXPECT_EQ(with.at<cv::Vec3b>(95 + 100, 700 + 100), magenta);
  const cv::Mat without =
      cv::imread(writeReport((dir / "b").string(), r.record(), "", ReportOptions()).sheet_png);
  EXPECT_EQ(magentaPixels(without), 0);
  // A ground view that does not decode is left out: the sheet is written all the same.
  {
    std::ofstream f(dir / "broken.png");
    f << "not a png";
  }
  const cv::Mat broken = cv::imread(writeReport((dir / "c").string(), r.record(), "",
                                                ReportOptions(), (dir / "broken.png").string())
                                        .sheet_png);
  EXPECT_EQ(broken.cols, 1600);
  EXPECT_EQ(magentaPixels(broken), 0);
  fs::remove_all(dir);
}

TEST(Report, TheStagesFiguresStayInTheirColumnWhateverTheirNumberAndLength) {
  const fs::path dir = fs::temp_directory_path() / "autocal_test_run_report_columns";
  fs::remove_all(dir);
  // Three stages done, each with long-named figures (as the odometry stage's are), and the same
  // run with none: the plots below and the sheet's right edge are the same in both.
  auto run = [](bool figures) {
    RunRecorder r("bot", {"camera", "wheels", "odometry"});
    for (int k = 0; k < 3; ++k) {
      const std::string stage = k == 0 ? "camera" : k == 1 ? "wheels" : "odometry";
      std::vector<std::pair<std::string, double>> figs;
      if (figures) {
        for (int i = 0; i < 12; ++i)
          figs.push_back({"right_pulses_per_round_left_stopped_" + std::to_string(i), 427.7412});
      }
      r.addStatus(status(10.0 * k + 1, stage + "/run", kRunning, "running"));
      r.addStatus(status(10.0 * k + 9, stage + "/write", kDone, "wrote " + stage + ".yaml", figs));
    }
    return r.record();
  };
  const cv::Mat with = cv::imread(
      writeReport((dir / "a").string(), run(true), "", ReportOptions()).sheet_png);
  const cv::Mat without = cv::imread(
      writeReport((dir / "b").string(), run(false), "", ReportOptions()).sheet_png);
  ASSERT_FALSE(with.empty());
  ASSERT_FALSE(without.empty());
  auto differing = [&](cv::Rect area) {
    cv::Mat diff;
    cv::absdiff(with(area), without(area), diff);
    return cv::countNonZero(diff.reshape(1));
  };
  // The path and the trim plots, the panels above, and the last columns of the sheet.
  EXPECT_EQ(differing(cv::Rect(0, 656, 1185, 384)), 0) << "figures drawn over the plots";
  EXPECT_EQ(differing(cv::Rect(1030, 80, 570, 280)), 0) << "figures drawn over the panels";
  EXPECT_EQ(differing(cv::Rect(1594, 0, 6, 1040)), 0) << "figures run off the sheet";
  // And the figures are there.
  EXPECT_GT(differing(cv::Rect(1030, 360, 570, 296)), 1000);
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(CameraView, DrawsTheDetectionsOutlines) {
  cv::Mat image(120, 160, CV_8UC3, cv::Scalar(128, 128, 128));
  markers::TagDetection d;
  d.id = 7;
  d.corners_px = {cv::Point2d(40, 80), cv::Point2d(100, 80), cv::Point2d(100, 20),
                  cv::Point2d(40, 20)};
  d.center_px = {70, 50};
  drawTagDetections(image, {d});
  // The first edge red, the others green; far from the outline the image is untouched.
  EXPECT_EQ(image.at<cv::Vec3b>(80, 70), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(50, 100), cv::Vec3b(0, 220, 0));
  EXPECT_EQ(image.at<cv::Vec3b>(20, 70), cv::Vec3b(0, 220, 0));
  EXPECT_EQ(image.at<cv::Vec3b>(5, 5), cv::Vec3b(128, 128, 128));
  EXPECT_EQ(image.at<cv::Vec3b>(100, 150), cv::Vec3b(128, 128, 128));
}
