#include "wheel_calibration_node.h"

#include <camera_calibration_parsers/parse.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/io/image_file.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"
#include "autocal_ros/tag_params.h"

namespace autocal {
namespace wheels {

void WheelCalibrationNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkCalibrationRoot(calibration_root);
  ros_layer::checkLength("tag_size_m", run.detector.tag_size_m, ranges::kTagSize);
  ros_layer::checkLength("camera_height_m", run.mount.height_m, ranges::kCameraHeight);
  ros_layer::checkParam(image_transport == "compressed" || image_transport == "raw",
                        "image_transport",
                        "must be 'compressed' or 'raw', not '" + image_transport + "'");
  ros_layer::checkParam(std::isfinite(control_rate_hz) && control_rate_hz >= 20, "control_rate_hz",
                        "must be >= 20 Hz");
  ros_layer::checkParam(std::isfinite(camera_stage_wait_s) && camera_stage_wait_s >= 0,
                        "camera_stage_wait_s", "must be >= 0");
  ros_layer::checkParam(std::isfinite(connect_wait_s) && connect_wait_s >= 0, "connect_wait_s",
                        "must be >= 0");
  ros_layer::checkParam(std::isfinite(status_rate_hz) && status_rate_hz > 0, "status_rate_hz",
                        "must be > 0");
  ros_layer::checkParam(std::isfinite(deadband_guess) && deadband_guess < 0.9, "deadband_guess",
                        "must be < 0.9 (negative: automatic)");
  ros_layer::checkParam(std::isfinite(deadband_guess_resolution) &&
                            deadband_guess_resolution >= 0 && deadband_guess_resolution < 0.5,
                        "deadband_guess_resolution", "must be in [0, 0.5) (0: each its own)");
  ros_layer::checkParam(!recorded_status_topic.empty(), "recorded_status_topic",
                        "must not be empty");
  ros_layer::checkParam(std::isfinite(recording_end_wait_s) && recording_end_wait_s > 0,
                        "recording_end_wait_s", "must be > 0");
  ros_layer::checkParam(std::isfinite(intrinsics_wait_s) && intrinsics_wait_s > 0,
                        "intrinsics_wait_s", "must be > 0");
  ros_layer::validateParams(run);
}

namespace {

WheelCalibrationNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "wheel_calibration_node");
  WheelCalibrationNodeOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("resume", o.resume);
  p.get("intrinsics_file", o.intrinsics_file);
  p.get("camera_stage_wait_s", o.camera_stage_wait_s);
  p.get("image_transport", o.image_transport);
  p.get("control_rate_hz", o.control_rate_hz);
  p.get("connect_wait_s", o.connect_wait_s);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("update_kinematics_node", o.update_kinematics_node);
  p.get("deadband_guess", o.deadband_guess);
  p.get("deadband_guess_resolution", o.deadband_guess_resolution);
  p.get("passive", o.passive);
  p.get("recorded_status_topic", o.recorded_status_topic);
  p.get("recording_end_wait_s", o.recording_end_wait_s);
  p.get("intrinsics_wait_s", o.intrinsics_wait_s);

  WheelRunOptions& r = o.run;
  ros_layer::readTagParams(p, r.detector, r.heading, r.mount);
  p.get("min_update", r.trim.min_update);
  p.get("ignored_to_converge", r.trim.ignored_to_converge);
  p.get("damping", r.trim.damping);
  p.get("full_step_above", r.trim.full_step_above);
  p.get("max_iterations", r.trim.max_iterations);
  p.get("mean_of_drives", r.trim.mean_of_drives);
  p.get("max_mean_error", r.trim.max_mean_error);
  p.get("more_drives_for_mean", r.trim.more_drives_for_mean);
  p.get("compensate_deadband", r.compensate_deadband);
  p.get("drive_speed_mps", r.drive_speed_mps);
  p.get("back_speed_mps", r.back_speed_mps);
  p.get("drive_s", r.drive_s);
  p.get("min_drive_s", r.min_drive_s);
  p.get("max_drive_turn_rad", r.max_drive_turn_rad);
  p.get("align_tolerance_rad", r.align_tolerance_rad);
  p.get("realign_above_rad", r.realign_above_rad);
  p.get("turn_duty_margin", r.turn_duty_margin);
  p.get("max_search_turn_rad", r.max_search_turn_rad);
  p.get("heading_frames", r.heading_frames);
  p.get("leave_speed_mps", r.leave_speed_mps);
  p.get("leave_clear_s", r.leave_clear_s);
  p.get("exit_extra_m", r.exit_extra_m);
  p.get("max_leave_m", r.max_leave_m);
  p.get("camera_timeout_s", r.camera_timeout_s);
  p.get("encoder_timeout_s", r.encoder_timeout_s);
  p.get("max_duration_s", r.max_duration_s);
  r.extrinsics_spins = 4;  // the node writes the camera's extrinsics by default
  p.get("extrinsics_spins", r.extrinsics_spins);
  p.get("extrinsics_spin_rad", r.extrinsics_spin_rad);
  p.get("extrinsics_drive_m", r.extrinsics_drive_m);
  p.get("extrinsics_drives", r.extrinsics_drives);
  p.get("extrinsics_max_floor_sigma_m", r.extrinsics_max_floor_sigma_m);
  o.validate();
  return o;
}

/// A paired count (EncoderPairer's, fractional where interpolated) as the stage takes it.
int count(double ticks) { return static_cast<int>(std::lround(ticks)); }

double figure(const autocal::CalibrationStatus& msg, const std::string& name) {
  for (size_t i = 0; i < msg.figure_names.size() && i < msg.figure_values.size(); ++i)
    if (msg.figure_names[i] == name) return msg.figure_values[i];
  return -1;
}

/// The file the camera stage's DONE carries (written, or kept by a resumed run).
std::string fileOfDone(const autocal::CalibrationStatus& done) {
  if (done.file.empty())
    throw CalibrationError("the camera stage's DONE names no file (\"" + done.text +
                           "\"), and no ~intrinsics_file");
  return done.file;
}

}  // namespace

WheelCalibrationNode::WheelCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readOptions(nh, pnh)),
      status_throttle_(options_.status_rate_hz) {
  kinematics_path_ = kinematicsPath(options_.calibration_root, options_.veh);
  extrinsics_path_ = extrinsics::extrinsicsPath(options_.calibration_root, options_.veh);
  before_ = readKinematicsFileOrDefaults(kinematics_path_);  // a malformed file is an error
  // The output folder, before the robot moves (the file is written after the last drive).
  checkWritableFolder(std::filesystem::path(kinematics_path_).parent_path().string());
  if (options_.run.extrinsics_spins > 0 && !options_.passive)
    checkWritableFolder(std::filesystem::path(extrinsics_path_).parent_path().string());
  status_ = ros_layer::StatusPublisher(nh_, "calibration/status");
  detections_pub_ =
      nh_.advertise<dtmsg::AprilTagDetectionArray>("apriltag_detector_node/detections", 5);
  status_.running("wheels/wait", 0,
                  options_.intrinsics_file.empty() ? "waiting for the camera stage"
                                                   : "waiting for the camera and the encoders");
}

void WheelCalibrationNode::waitForCameraStage() {
  if (!options_.intrinsics_file.empty()) return;
  ROS_INFO("wheel_calibration_node: waiting for the camera stage's DONE on %s",
           status_.topic().c_str());
  const autocal::CalibrationStatus done =
      ros_layer::waitForStage(nh_, "camera", options_.camera_stage_wait_s);  // throws
  if (!ros_layer::ok()) return;
  options_.intrinsics_file = fileOfDone(done);
  camera_min_duty_left_ = figure(done, "min_duty_left_forward");
  camera_min_duty_right_ = figure(done, "min_duty_right_forward");
}

void WheelCalibrationNode::connect() {
  wheels_ = ros_layer::connectStage(
      nh_, [this] { return frames_->publishers() > 0 && encoders_->connected(); },
      options_.connect_wait_s);
}

void WheelCalibrationNode::publishDetections(const ros::Time& stamp) {
  if (detections_pub_.getNumSubscribers() == 0) return;
  dtmsg::AprilTagDetectionArray msg;
  msg.header.stamp = stamp;
  for (const auto& d : run_->lastDetections())
    msg.detections.push_back(ros_layer::toTagDetectionMsg(d));
  detections_pub_.publish(msg);
}

void WheelCalibrationNode::publishStatus(bool force) {
  const std::string phase = std::string("wheels/") + name(run_->stage());
  if (!status_throttle_.due(phase, ros::Time::now().toSec(), force)) return;
  const auto& hist = run_->estimator().history();
  if (status_throttle_.keyChanged() || hist.size() != last_drives_) {
    ROS_INFO("wheel_calibration_node: %s: %s", phase.c_str(), run_->describe().c_str());
    last_drives_ = hist.size();
  }
  const auto& h = run_->estimator().history();
  status_.running(
      phase, run_->progress(), run_->describe(),
      {{"iteration", static_cast<double>(h.size())},
       {"k", run_->estimator().ratio()},
       {"trim", run_->result().trim},
       {"last_dtheta_rad", h.empty() ? 0.0 : h.back().delta_theta_rad},
       {"heading_rad", std::isfinite(run_->lastHeadingRad()) ? run_->lastHeadingRad() : 0.0},
       {"frames_dropped", static_cast<double>(frames_->dropped())},
       {"elapsed_s", run_->elapsedS()}});
}

void WheelCalibrationNode::run() {
  if (options_.resume &&
      ros_layer::resumeStage(status_, options_.calibration_root, options_.veh, "wheels"))
    return;
  if (options_.passive) return runPassive();
  waitForCameraStage();
  if (!ros_layer::ok()) return;
  const CameraIntrinsics intrinsics = readIntrinsics();
  WheelRunOptions r = options_.run;
  r.kinematics = before_;
  double guess_left = options_.deadband_guess, guess_right = options_.deadband_guess;
  if (guess_left < 0 && camera_min_duty_left_ >= 0 && camera_min_duty_right_ >= 0) {
    const DeadbandGuesses g = deadbandGuesses(camera_min_duty_left_, camera_min_duty_right_,
                                              options_.deadband_guess_resolution);
    guess_left = g.left;
    guess_right = g.right;
  } else if (guess_left < 0) {
    guess_left = camera_min_duty_left_ >= 0 ? camera_min_duty_left_ : before_.deadband_left;
    guess_right = camera_min_duty_right_ >= 0 ? camera_min_duty_right_ : before_.deadband_right;
  }
  r.kinematics.deadband_left = guess_left;
  r.kinematics.deadband_right = guess_right;
  ROS_INFO(
      "wheel_calibration_node: intrinsics %s (fx %.1f), kinematics %s, deadband guess %.3f/%.3f",
      options_.intrinsics_file.c_str(), intrinsics.fx, kinematics_path_.c_str(), guess_left,
      guess_right);
  run_ = std::make_unique<WheelRun>(r, intrinsics);

  frames_ = std::make_unique<ros_layer::FrameInput>(
      nh_, options_.image_transport, "wheel_calibration_node",
      [this](const ros::Time& stamp) {
        arrivals_.frames = true;
        run_->noteFrameArrived(ros::Time::now().toSec());
        return run_->wantsFrame(stamp.toSec());
      },
      [this](const ros::Time& stamp, const cv::Mat& image, const std::string&) {
        run_->addFrame(stamp.toSec(), image);
        if (run_->stage() == WheelRunStage::kExtrinsics) image.copyTo(ground_frame_);
        publishDetections(stamp);
      },
      &error_);
  frames_->holdToSize(intrinsics.imageSize());
  encoders_ = std::make_unique<ros_layer::EncoderInput>(
      nh_, [this](const ros::Time&, int, int, int) { arrivals_.encoders = true; }, &error_,
      [this](int side, const ros::Time& stamp, std::int32_t ticks, int resolution) {
        for (const EncoderPairer::Pair& p : pairer_.add(side, stamp.toSec(), ticks)) {
          run_->addEncoders(p.stamp_s, count(p.left_ticks), count(p.right_ticks), resolution,
                            ros::Time::now().toSec());
        }
      });
  connect();
  if (!ros_layer::runStageLoop(
          *run_, [this] { return run_->done(); }, options_.control_rate_hz, error_, arrivals_,
          wheels_, [this] { publishStatus(false); }))
    return;  // interrupted: runNode stops the wheels
  finish();
}

CameraIntrinsics WheelCalibrationNode::readIntrinsics() const {
  sensor_msgs::CameraInfo info;
  std::string camera_name;
  if (!camera_calibration_parsers::readCalibration(options_.intrinsics_file, camera_name, info) ||
      info.K[0] <= 0) {
    throw ConfigError("the camera intrinsics '" + options_.intrinsics_file +
                      "' cannot be read (the wheel stage needs the calibrated camera)");
  }
  return ros_layer::fromCameraInfo(info);
}

void WheelCalibrationNode::onStageStatus(const autocal::CalibrationStatus::ConstPtr& msg) {
  if (msg->phase.rfind("camera/", 0) != 0 || !options_.intrinsics_file.empty()) return;
  if (msg->state == autocal::CalibrationStatus::STATE_FAILED)
    camera_failure_ = msg->failure_reason.empty() ? msg->text : msg->failure_reason;
  if (msg->state != autocal::CalibrationStatus::STATE_DONE) return;
  try {
    options_.intrinsics_file = fileOfDone(*msg);
  } catch (...) {
    error_ = std::current_exception();
  }
}

namespace {
/// Messages of each input that wait while the passive node is busy: rosbag play feeds a recording
/// faster than real time, and a lost encoder reading or frame changes what the replay computes.
constexpr uint32_t kReplayQueue = 2000;
}  // namespace

void WheelCalibrationNode::runPassive() {
  WheelRunOptions r = options_.run;
  r.kinematics = before_;
  ROS_INFO(
      "wheel_calibration_node: passive: replaying the wheel stage from the recording "
      "(recorded status on %s), kinematics %s",
      ros::names::resolve(nh_.resolveName(options_.recorded_status_topic)).c_str(),
      kinematics_path_.c_str());
  if (options_.intrinsics_file.empty())
    stage_status_sub_ =
        nh_.subscribe("calibration/status", 20, &WheelCalibrationNode::onStageStatus, this);
  bool intrinsics_set = false;
  auto setIntrinsics = [&] {
    if (intrinsics_set || !replay_ || options_.intrinsics_file.empty()) return;
    replay_->setIntrinsics(readIntrinsics());
    intrinsics_set = true;
    ROS_INFO("wheel_calibration_node: replay: intrinsics %s", options_.intrinsics_file.c_str());
  };
  recording_ = std::make_unique<ros_layer::RecordingFollower>(
      nh_, "wheels", options_.recorded_status_topic,
      [this](const ros::Time& stamp, const WheelDuties& d) {
        if (replay_) replay_->addCommand(stamp.toSec(), d);
      },
      [this, r](const ros::Time&, const std::string& phase) {
        // The recorded stage begins after its wait for the camera stage: from then on its
        // commands, encoders and frames are the wheel stage's.
        if (!replay_ && phase != "wheels/wait") replay_ = std::make_unique<WheelReplay>(r);
      },
      &error_);
  frames_ = std::make_unique<ros_layer::FrameInput>(
      nh_, options_.image_transport, "wheel_calibration_node",
      [this](const ros::Time& stamp) {
        recording_->noteMessage();
        return replay_ && replay_->wantsFrame(stamp.toSec());
      },
      [this](const ros::Time& stamp, const cv::Mat& image, const std::string&) {
        replay_->addFrame(stamp.toSec(), image);
      },
      &error_, kReplayQueue);
  encoders_ = std::make_unique<ros_layer::EncoderInput>(
      nh_, [this](const ros::Time&, int, int, int) { recording_->noteMessage(); }, &error_,
      [this](int side, const ros::Time& stamp, std::int32_t ticks, int resolution) {
        for (const EncoderPairer::Pair& p : pairer_.add(side, stamp.toSec(), ticks)) {
          if (replay_)
            replay_->addEncoders(p.stamp_s, count(p.left_ticks), count(p.right_ticks), resolution);
        }
      },
      kReplayQueue);

  auto describe = [&] {
    return replay_ ? replay_->describe() : std::string("waiting for the recorded wheel stage");
  };
  ros::WallRate rate(options_.control_rate_hz);
  ros::WallTime last_status;
  auto spin = [&](const std::string& phase, double progress) {
    ros::spinOnce();
    if (error_) std::rethrow_exception(error_);
    if (!camera_failure_.empty())
      throw CalibrationError("the camera stage failed (" + camera_failure_ +
                             "): the wheel stage needs its intrinsics");
    setIntrinsics();
    if ((ros::WallTime::now() - last_status).toSec() >= 1.0 / options_.status_rate_hz) {
      status_.running(phase, progress, describe(),
                      {{"drives", replay_ ? static_cast<double>(replay_->drives()) : 0.0},
                       {"stills", replay_ ? static_cast<double>(replay_->stills()) : 0.0},
                       {"frames_dropped", static_cast<double>(frames_->dropped())}});
      last_status = ros::WallTime::now();
    }
    rate.sleep();
  };
  while (ros_layer::ok() && !recording_->stageEnded()) {
    // The replay keeps pace with the recording: its progress is the recorded stage's.
    spin("wheels/replay", 0.9 * recording_->progress());
    if (recording_->recordingEnded(options_.recording_end_wait_s)) {
      throw InputError("the recording ended before its wheel stage did (" + describe() +
                       (recording_->stageStarted()
                            ? "; the stage's end is not in it)"
                            : "; no status of the wheel stage on " + recording_->statusTopic() +
                                  ": was calibration/status recorded?)"));
    }
  }
  if (!ros_layer::ok()) return;
  if (!replay_)
    throw InputError("the recorded wheel stage ended before it began: nothing to replay (" +
                     recording_->failure() + ")");
  if (recording_->stageFailed())
    ROS_WARN(
        "wheel_calibration_node: the recorded wheel stage FAILED (%s); recomputing what it "
        "drove",
        recording_->failure().c_str());
  const ros::WallTime wait_end =
      ros::WallTime::now() + ros::WallDuration(options_.intrinsics_wait_s);
  while (ros_layer::ok() && !intrinsics_set) {
    if (ros::WallTime::now() > wait_end)
      throw CalibrationError("no intrinsics " + std::to_string(options_.intrinsics_wait_s) +
                             " s after the recording's wheel stage ended: the camera stage gave "
                             "no DONE on calibration/status, and no ~intrinsics_file");
    spin("wheels/wait", 0.9);
  }
  if (!ros_layer::ok()) return;
  const WheelReplayResult result = replay_->result();  // throws
  if (!result.converged) {
    throw CalibrationError("the replayed iteration did not converge (" +
                           std::to_string(result.iterations.size()) + " updates over " +
                           std::to_string(result.drives) + " drives): nothing written");
  }
  // Each update of the replayed iteration, as the live stage published them (the report's k plot).
  for (std::size_t i = 0; i < result.iterations.size(); ++i) {
    const TrimIteration& it = result.iterations[i];
    status_.running("wheels/replay", 0.95, describe(),
                    {{"iteration", static_cast<double>(i + 1)},
                     {"k", it.ratio_after},
                     {"trim", trimFromSpeedRatio(it.ratio_after, result.kinematics.gain)},
                     {"last_dtheta_rad", it.delta_theta_rad}});
  }
  status_.running("wheels/write", 0.98, describe());
  writeKinematicsFile(kinematics_path_, result.kinematics);  // validates first; throws on failure
  const KinematicsParams& k = result.kinematics;
  ROS_INFO(
      "wheel_calibration_node: replay: wrote %s: trim %.4f, deadband %.4f/%.4f, %zu updates "
      "over %d drives, %d/%d stills measured",
      kinematics_path_.c_str(), k.trim, k.deadband_left, k.deadband_right, result.iterations.size(),
      result.drives, result.measured, result.stills);
  status_.wrote("wheels/write", kinematics_path_,
                {{"trim", k.trim},
                 {"trim_before", before_.trim},
                 {"k", result.iterations.back().ratio_after},
                 {"deadband_left", k.deadband_left},
                 {"deadband_right", k.deadband_right},
                 {"drives", static_cast<double>(result.iterations.size())},
                 {"last_dtheta_rad", result.iterations.back().delta_theta_rad},
                 {"frames_dropped", static_cast<double>(frames_->dropped())}});
}

ros_layer::StatusPublisher::Figures WheelCalibrationNode::writeExtrinsics() {
  if (options_.run.extrinsics_spins == 0) return {};
  const extrinsics::TagMountResult* x = run_->extrinsicsResult();
  if (!x) {
    // The trim is right all the same: the stage succeeds, without the extrinsics file.
    ROS_WARN("wheel_calibration_node: no camera extrinsics written: %s",
             run_->extrinsicsFailure().c_str());
    return {{"extrinsics_written", 0.0}};
  }
  const extrinsics::CameraInfoRectification camera =
      extrinsics::loadRectification(options_.intrinsics_file);
  const extrinsics::CameraMount& m = x->mount;
  const Eigen::Matrix3d H = extrinsics::homographyFromMount(m, camera.rectified);
  writeFileAtomically(
      extrinsics_path_,
      extrinsics::extrinsicsYaml(
          H, m, x->has_sigma ? &x->sigma : nullptr,
          {{"plane_rms_m", x->plane_rms_m},
           {"rejected_sightings", static_cast<double>(x->rejected)},
           {"turn_centre_rms_m", x->centre_rms_m},
           {"yaw_spread_rad", x->yaw_spread_rad},
           {"drives", static_cast<double>(x->straight)},
           {"turns", static_cast<double>(x->spins)}},
          camera.rectified,
          "the floor tags of the wheel stage (intrinsics " + options_.intrinsics_file + ")",
          odometry::utcNowIso8601()));
  if (!ground_frame_.empty()) {
    // For a person to check: the floor grid where the homography puts it, over the last still.
    cv::Mat view = extrinsics::rectifyImage(ground_frame_, camera);
    if (view.channels() == 1) cv::cvtColor(view, view, cv::COLOR_GRAY2BGR);
    extrinsics::drawFloorGrid(view, H);
    writePngAtomically(extrinsics::groundViewPath(extrinsics_path_), view);
  }
  ROS_INFO(
      "wheel_calibration_node: wrote %s: camera %.1f mm high, pitch %.2f deg, roll %.2f deg, yaw "
      "%.2f deg, %.1f mm ahead of the axle, %.1f mm left (%d drives, %d turns)",
      extrinsics_path_.c_str(), 1e3 * m.height_m, m.pitch_rad * 180 / M_PI, m.roll_rad * 180 / M_PI,
      m.yaw_rad * 180 / M_PI, 1e3 * m.x_m, 1e3 * m.y_m, x->straight, x->spins);
  return {{"extrinsics_written", 1.0},
          {"camera_height_m", m.height_m},
          {"camera_pitch_rad", m.pitch_rad},
          {"camera_roll_rad", m.roll_rad},
          {"camera_yaw_rad", m.yaw_rad},
          {"camera_x_m", m.x_m},
          {"camera_y_m", m.y_m}};
}

void WheelCalibrationNode::finish() {
  const KinematicsParams result = run_->result();
  status_.running("wheels/write", 0.98, run_->describe());
  writeKinematicsFile(kinematics_path_, result);  // validates first; throws on failure
  const ros_layer::StatusPublisher::Figures extrinsic_figures = writeExtrinsics();
  if (options_.update_kinematics_node) {
    // The running kinematics node polls its parameters: the new trim applies without a restart.
    nh_.setParam("kinematics_node/trim", result.trim);
    nh_.setParam("kinematics_node/deadband_left", result.deadband_left);
    nh_.setParam("kinematics_node/deadband_right", result.deadband_right);
  }
  const auto& h = run_->estimator().history();
  ROS_INFO(
      "wheel_calibration_node: wrote %s: trim %.4f (was %.4f), k %.5f, deadband %.4f/%.4f, %zu "
      "drives, %.1f s",
      kinematics_path_.c_str(), result.trim, before_.trim, run_->estimator().ratio(),
      result.deadband_left, result.deadband_right, h.size(), run_->elapsedS());
  ros_layer::StatusPublisher::Figures figures = {
      {"trim", result.trim},
      {"trim_before", before_.trim},
      {"k", run_->estimator().ratio()},
      {"deadband_left", result.deadband_left},
      {"deadband_right", result.deadband_right},
      {"drives", static_cast<double>(h.size())},
      {"last_dtheta_rad", h.empty() ? 0.0 : h.back().delta_theta_rad},
      {"frames_dropped", static_cast<double>(frames_->dropped())},
      {"elapsed_s", run_->elapsedS()}};
  figures.insert(figures.end(), extrinsic_figures.begin(), extrinsic_figures.end());
  // The stage succeeds without the extrinsics; its DONE says why they are missing.
  const std::string missing = options_.run.extrinsics_spins > 0 && !run_->extrinsicsResult()
                                  ? "; no camera extrinsics: " + run_->extrinsicsFailure()
                                  : "";
  status_.done("wheels/write", "wrote " + kinematics_path_ + missing, figures, kinematics_path_);
}

}  // namespace wheels
}  // namespace autocal
