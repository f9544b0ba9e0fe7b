// calibrate_camera: offline camera intrinsic calibration from an image folder or a bag.
//   rosrun autocal calibrate_camera --images 'DIR/*.jpg' --board 9x6 --square 0.025 --out FILE.yaml
//   rosrun autocal calibrate_camera --bag FILE.bag --topic /veh/camera_node/image/compressed ...
// Writes the camera_info YAML (camera_calibration_parsers, atomically) only when the result passes
// the quality gate, and beside it FILE_views/ with the views used (image + corners) for audit.
// Exit codes: the one table of doc/calibration_run.md "Exit codes" (autocal/exit_codes.h);
// doc/nodes/calibrate_camera.md.
#include <cv_bridge/cv_bridge.h>
#include <glob.h>
#include <ros/package.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>

#include "autocal/camera/calibration.h"
#include "autocal/camera/calibration_files.h"
#include "autocal/camera/camera_config.h"
#include "autocal/camera/sweep_run.h"
#include "autocal/camera/view_selection.h"
#include "autocal/errors.h"
#include "autocal/exit_codes.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/parallel.h"
#include "autocal_ros/msg_conversion.h"

namespace fs = std::filesystem;
using namespace autocal;
using namespace autocal::camera;

namespace {

const char* kUsage =
    "usage: calibrate_camera (--images 'GLOB' | --bag FILE --topic TOPIC) --out FILE.yaml\n"
    "                        [--board 9x6] [--square 0.025] [--model "
    "plumb_bob|rational_polynomial|equidistant]\n"
    "                        [--config FILE] [--camera-name NAME] [--min-novelty X] [--holdout]\n"
    "                        [--novel-only]\n";

struct Args {
  std::string images, bag, topic, out, config, model, camera_name = "camera", board;
  double square_m = 0;  ///< 0: the config's
  double min_novelty = -1;
  bool holdout = false;
  bool novel_only = false;  ///< calibrate on the novel views only (not every sharp one)
};

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--help" || k == "-h") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (k == "--holdout") {
      a.holdout = true;
      continue;
    }
    if (k == "--novel-only") {
      a.novel_only = true;
      continue;
    }
    if (i + 1 >= argc) throw UsageError(k + " needs a value");
    const std::string v = argv[++i];
    if (k == "--images")
      a.images = v;
    else if (k == "--bag")
      a.bag = v;
    else if (k == "--topic")
      a.topic = v;
    else if (k == "--out")
      a.out = v;
    else if (k == "--config")
      a.config = v;
    else if (k == "--model")
      a.model = v;
    else if (k == "--camera-name")
      a.camera_name = v;
    else if (k == "--board")
      a.board = v;
    else if (k == "--square") {
      a.square_m = parseNumberArg(k, v);
      if (!(a.square_m > 0 && a.square_m < 0.5)) {
        throw UsageError(k + ": the side of a square in metres, within (0, 0.5), got " + v +
                         (a.square_m >= 1 ? " (millimetres? 25 mm is 0.025)" : ""));
      }
    } else if (k == "--min-novelty") {
      a.min_novelty = parseNumberArg(k, v);
    } else {
      throw UsageError("unknown option " + k);
    }
  }
  if (a.images.empty() == a.bag.empty()) throw UsageError("give exactly one of --images and --bag");
  if (!a.bag.empty() && a.topic.empty()) throw UsageError("--bag needs --topic");
  if (a.out.empty()) throw UsageError("--out is required");
  return a;
}

std::string defaultConfigPath() {
  // The source tree this binary was built from, else the package as ROS finds it.
  const std::string built = std::string(AUTOCAL_SOURCE_DIR) + "/config/camera_calibration.yaml";
  if (fs::exists(built)) return built;
  return ros::package::getPath("autocal") + "/config/camera_calibration.yaml";
}

// A frame of the input: its name, its place, and how to decode it (an empty image: undecodable).
struct PendingFrame {
  std::string name;
  size_t index = 0;
  size_t total = 0;  ///< frames in the input
  std::function<cv::Mat()> decode;
};

// Takes a decoded frame (empty: undecodable) with the boards found in it, in the input's order.
using FrameSink =
    std::function<void(const PendingFrame&, const cv::Mat& image, DetectedFrame detected)>;

// Frames are decoded and their boards detected a batch at a time, one frame per thread, and then
// handed to the sink in order: the views kept are the same as one frame after another, and most
// of the time before the fit is the decoding and the detection.
class FrameBatches {
 public:
  FrameBatches(const ViewCollector& collector, int threads, const FrameSink& sink)
      : collector_(collector),
        threads_(threads),
        batch_size_(4 * threadCount(1000, threads)),
        sink_(sink) {}

  void add(PendingFrame frame) {
    batch_.push_back(std::move(frame));
    if (batch_.size() >= batch_size_) flush();
  }

  // A frame that fails to decode or detect (an unreadable file) throws here, after the frames
  // before it have reached the sink.
  void flush() {
    const size_t n = batch_.size();
    std::vector<cv::Mat> images(n);
    std::vector<DetectedFrame> detected(n);
    std::vector<std::exception_ptr> errors(n);
    forEachIndex(n, threads_, [&](size_t k) {
      try {
        images[k] = batch_[k].decode();
        if (!images[k].empty()) detected[k] = collector_.detect(images[k], batch_[k].name);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    });
    std::vector<PendingFrame> batch = std::move(batch_);
    batch_.clear();
    for (size_t k = 0; k < n; ++k) {
      if (errors[k]) std::rethrow_exception(errors[k]);
      sink_(batch[k], images[k], std::move(detected[k]));
    }
  }

 private:
  const ViewCollector& collector_;
  int threads_;
  size_t batch_size_;
  FrameSink sink_;
  std::vector<PendingFrame> batch_;
};

// The files matching `pattern`, in name order; throws InputError when none does.
std::vector<std::string> imageFiles(const std::string& pattern) {
  glob_t g;
  const int rc = ::glob(pattern.c_str(), 0, nullptr, &g);
  std::vector<std::string> files;
  if (rc == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) files.push_back(g.gl_pathv[i]);
  }
  globfree(&g);
  if (files.empty()) throw InputError("--images '" + pattern + "': no file matches");
  return files;
}

void readImages(const std::vector<std::string>& files, FrameBatches& frames) {
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string file = files[i];
    // Grey: the detection and the calibration use grey only (and it decodes faster).
    frames.add(
        {file, i, files.size(), [file] { return readImageFile(file, cv::IMREAD_GRAYSCALE); }});
  }
  frames.flush();
}

// Returns the number of frames on `topic`.
size_t readBag(const std::string& path, const std::string& topic, FrameBatches& frames) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError(path + ": cannot open the bag: " + e.what());
  }
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  if (view.size() == 0) {
    std::set<std::string> topics;
    rosbag::View all(bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections())
      topics.insert(c->topic + " (" + c->datatype + ")");
    std::string list;
    for (const auto& t : topics) list += "\n  " + t;
    throw InputError(path + ": no messages on topic '" + topic +
                     "'; the bag has:" + (list.empty() ? " nothing" : list));
  }
  const size_t total = view.size();
  size_t index = 0;
  try {
    for (const rosbag::MessageInstance& m : view) {
      char name[160];
      std::snprintf(name, sizeof name, "%s@%.3f", topic.c_str(), m.getTime().toSec());
      std::function<cv::Mat()> decode;
      if (auto c = m.instantiate<sensor_msgs::CompressedImage>()) {
        decode = [c] {
          // A frame cut short decodes with grey rows: refused as undecodable.
          if (c->data.empty() || !truncatedImage(c->data).empty()) return cv::Mat();
          return cv::imdecode(c->data, cv::IMREAD_COLOR);
        };
      } else if (auto r = m.instantiate<sensor_msgs::Image>()) {
        decode = [r] {
          try {
            return cv_bridge::toCvCopy(r, "bgr8")->image;
          } catch (const cv_bridge::Exception&) {
            return cv::Mat();
          }
        };
      } else {
        throw InputError(path + ": topic '" + topic + "' carries " + m.getDataType() +
                         ", not sensor_msgs/CompressedImage or sensor_msgs/Image");
      }
      frames.add({name, index, total, std::move(decode)});
      ++index;
    }
  } catch (const ros::Exception& e) {
    // rosbag and deserialisation errors: a bag cut off or corrupt in the middle: what was read so
    // far is not a complete input.
    frames.flush();
    throw InputError(path + ": the bag is corrupt or truncated after " + std::to_string(index) +
                     " of " + std::to_string(total) + " frames: " + e.what());
  }
  frames.flush();
  return total;
}

int run(const Args& args) {
  const auto t0 = std::chrono::steady_clock::now();
  CameraCalibrationConfig config =
      loadCameraCalibrationConfig(args.config.empty() ? defaultConfigPath() : args.config);
  if (!args.board.empty()) config.board.inner_corners = parseBoardSize(args.board);
  if (args.square_m > 0) config.board.square_size_m = args.square_m;
  const BoardSpec& board = config.board;
  if (!args.model.empty()) {
    // A model given is pinned: no other is tried.
    config.calibration.model = parseDistortionModel(args.model);
    config.calibration.fallback_models.clear();
  }
  if (args.min_novelty >= 0) config.selection.min_novelty = args.min_novelty;
  if (args.novel_only) config.selection.keep_sharp_views = false;
  config.validate();

  ViewCollector collector(board, config.detector, config.selection);
  std::map<int, cv::Mat> kept_frames;
  std::vector<std::string> refused;  // "name: reason"
  int frames_without_board = 0;
  std::vector<std::string> undecodable;
  auto sink = [&](const PendingFrame& frame, const cv::Mat& img, DetectedFrame detected) {
    const std::string& name = frame.name;
    const size_t i = frame.index, total = frame.total;
    if (img.empty()) {
      // A stream may carry a broken frame: refuse that frame, keep going.
      undecodable.push_back(name);
      return;
    }
    const int frame_index = collector.frames();
    const size_t fit_views_before = collector.calibrationViews().size();
    const FrameResult r = collector.add(std::move(detected), name);
    if (collector.calibrationViews().size() > fit_views_before) kept_frames[frame_index] = img;
    std::string what;
    if (r.boards_found == 0) {
      ++frames_without_board;
      refused.push_back(name + ": no board found");
      what = "no board";
    }
    for (size_t b = 0; b < r.decisions.size(); ++b) {
      const ViewDecision& d = r.decisions[b];
      const std::string label = r.decisions.size() > 1 ? " board " + std::to_string(b) : "";
      const bool fitted = d.kept || (d.sharp && config.selection.keep_sharp_views);
      if (!fitted) refused.push_back(name + label + ": " + d.reason);
      char edge[48];
      std::snprintf(edge, sizeof edge, " (edge width %.1f px)", d.edge_width_px);
      what += (what.empty() ? "" : "; ") + label.substr(label.empty() ? 0 : 1) +
              (label.empty() ? "" : " ") + d.reason +
              (!d.kept && fitted ? " (sharp: used by the fit)" : "") + (fitted ? edge : "");
    }
    if (r.any_kept()) what += "; coverage " + collector.coverage().summary();
    // Every image of a folder, and about every 2 % of a bag, gets a progress line.
    const size_t step = std::max<size_t>(1, total / 50);
    if (args.bag.empty() || r.any_kept() || i % step == 0 || i + 1 == total) {
      std::printf("[%zu/%zu] %s: %s\n", i + 1, total, name.c_str(), what.c_str());
      std::fflush(stdout);
    }
  };
  FrameBatches frames(collector, config.calibration.threads, sink);
  if (!args.images.empty()) {
    readImages(imageFiles(args.images), frames);
  } else {
    const size_t total = readBag(args.bag, args.topic, frames);
    if (undecodable.size() == total)
      throw InputError(args.bag + ": no frame on '" + args.topic + "' could be decoded");
    for (const auto& u : undecodable) refused.push_back(u + ": cannot decode the image");
  }
  const Coverage coverage = collector.coverage();
  std::printf("coverage: %s\n", coverage.summary().c_str());
  // Every sharp board (view_selection.keep_sharp_views), or only the novel ones.
  const std::vector<CalibrationView>& views = collector.calibrationViews();
  if (views.empty()) {
    throw CalibrationError("no usable view of a " + board.describe() + " board in " +
                           std::to_string(collector.frames()) +
                           " frames (check --board: inner corners, not squares)");
  }
  const auto t1 = std::chrono::steady_clock::now();
  const std::vector<std::vector<cv::Point2f>> corners =
      cornersToCalibrate(views, collector.imageSize(), config);
  const ModelChoice choice = calibrateChoosingModel(corners, collector.imageSize(), board,
                                                    config.calibration, config.quality_gate);
  const CalibrationResult& result = choice.result;
  const auto t2 = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(t2 - t0).count();

  const CameraIntrinsics& in = result.intrinsics;
  std::printf("\nmodel: %s, fitted %s\n", distortionModelName(in.distortion_model).c_str(),
              result.fitted_terms.c_str());
  std::printf("image: %dx%d\n", in.imageSize().width, in.imageSize().height);
  const auto sd = [&](size_t i) { return i < result.std_devs.size() ? result.std_devs[i] : 0.0; };
  if (result.std_devs.empty()) {
    std::printf("fx %.3f  fy %.3f  cx %.3f  cy %.3f px (no standard deviations)\n", in.fx, in.fy,
                in.cx, in.cy);
  } else {
    std::printf("fx %.3f (+-%.3f)  fy %.3f (+-%.3f)  cx %.3f (+-%.3f)  cy %.3f (+-%.3f) px\n",
                in.fx, sd(0), in.fy, sd(1), in.cx, sd(2), in.cy, sd(3));
  }
  std::printf("distortion:");
  for (size_t i = 0; i < in.distortion_coefficients.size(); ++i)
    std::printf(" %.6f", in.distortion_coefficients[i]);
  std::printf("\nRMS reprojection error: %.4f px\n", result.rms_px);
  if (result.uncertainty.valid) {
    const camera::ProjectionUncertainty& pu = result.uncertainty;
    std::printf(
        "projection uncertainty over the image (%dx%d grid, corner noise %.3f px): RMS %.3f px, "
        "worst %.3f px, lower half worst %.3f px\n",
        pu.grid.cols, pu.grid.rows, pu.corner_noise_px, pu.rms_px, pu.worst_px,
        pu.lower_half_worst_px);
  }
  if (result.halves.valid) {
    const camera::HalvesCrossValidation& h = result.halves;
    std::printf(
        "halves of %d views each: projection difference RMS %.3f px, worst %.3f px; %.2f times "
        "what their uncertainty allows (about 2 and more: the model does not explain all views)\n",
        h.views_each, h.rms_px, h.worst_px, h.ratio);
  }
  std::printf("views used: %zu of %zu %s (%zu novel; %d frames)\n", result.used_views.size(),
              views.size(), config.selection.keep_sharp_views ? "sharp views" : "novel views",
              collector.views().size(), collector.frames());
  for (size_t u = 0; u < result.used_views.size(); ++u) {
    std::printf("  used %s: RMS %.3f px\n",
                views[static_cast<size_t>(result.used_views[u])].source.c_str(),
                result.per_view_rms_px[u]);
  }
  if (result.dropped_corners) std::printf("outlier corners dropped: %d\n", result.dropped_corners);
  std::printf("refused: %zu\n", refused.size() + result.dropped_views.size());
  for (const auto& r : refused) std::printf("  refused %s\n", r.c_str());
  for (const auto& d : result.dropped_views) {
    std::printf("  refused %s: %s\n", views[static_cast<size_t>(d.index)].source.c_str(),
                d.reason.c_str());
  }
  std::printf("selection: %s\n", result.selection_reason.c_str());
  std::printf("images to intrinsics: %.3f s (reading and detection %.3f s, calibration %.3f s)\n",
              seconds, std::chrono::duration<double>(t1 - t0).count(),
              std::chrono::duration<double>(t2 - t1).count());

  if (args.holdout) {
    const HoldoutEvaluation ours = leaveOneOut(corners, collector.imageSize(), board,
                                               config.calibration, HoldoutMethod::kAutocal);
    const HoldoutEvaluation plain = leaveOneOut(corners, collector.imageSize(), board,
                                                config.calibration, HoldoutMethod::kPlainOpenCv);
    std::printf(
        "holdout: autocal %.4f px fx_spread %.3f px | plain_opencv %.4f px fx_spread %.3f px (%zu "
        "folds)\n",
        ours.mean_rms_px, ours.fx_spread_px, plain.mean_rms_px, plain.fx_spread_px, corners.size());
  }

  if (!choice.passed) {
    throw CalibrationError(std::string("the result fails the quality gate") +
                           (choice.refused.size() > 1 ? " with every lens model tried" : "") +
                           ", nothing written (" + args.out + " untouched):\n  " +
                           choice.refusals("\n  "));
  }
  if (!result.refused_models.empty())
    std::printf("refused first: %s\n", result.refused_models.c_str());
  writeCameraCalibration(args.out, ros_layer::cameraInfoYaml(in, args.camera_name), board, result,
                         views, kept_frames);
  const std::string views_dir = viewsDirFor(args.out);
  std::printf("wrote %s and %s/\n", args.out.c_str(), views_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return runCommand(
      "calibrate_camera", [&] { return run(parseArgs(argc, argv)); }, kUsage);
}
