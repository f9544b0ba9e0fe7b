#include "odometry_calibration_node.h"

#include <geometry_msgs/Point.h>
#include <std_msgs/Float64.h>

#include <cmath>
#include <filesystem>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/odometry/calibration_file.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/params.h"

namespace autocal {
namespace odometry {

void OdometryCalibrationNodeOptions::validate() const {
  ros_layer::checkParam(!veh.empty() && veh.find('/') == std::string::npos, "veh",
                        "must be a non-empty name without '/'");
  ros_layer::checkCalibrationRoot(calibration_root);
  ros_layer::checkParam(std::isfinite(wheel_radius_m) && wheel_radius_m > 0, "wheel_radius_m",
                        "must be > 0 [m]");
  ros_layer::checkParam(std::isfinite(wheelbase_m) && wheelbase_m > 0, "wheelbase_m",
                        "must be > 0 [m]");
  ros_layer::checkLength("wheel_radius_m", wheel_radius_m, ranges::kWheelRadius);
  ros_layer::checkLength("wheelbase_m", wheelbase_m, ranges::kWheelbase);
  if (method == "umbmark") ros_layer::checkLength("side_m", umbmark.side_m, ranges::kUmbmarkSide);
  if (method == "uah")
    ros_layer::checkLength("straight_length_m", run.straight_length_m, ranges::kStraightRun);
  ros_layer::checkParam(ticks_per_revolution >= 0, "ticks_per_revolution",
                        "must be >= 0 (0: from the encoder messages)");
  ros_layer::checkParam(std::isfinite(control_rate_hz) && control_rate_hz >= 20, "control_rate_hz",
                        "must be >= 20 Hz");
  ros_layer::checkParam(std::isfinite(connect_wait_s) && connect_wait_s >= 0, "connect_wait_s",
                        "must be >= 0");
  ros_layer::checkParam(std::isfinite(status_rate_hz) && status_rate_hz > 0, "status_rate_hz",
                        "must be > 0");
  ros_layer::checkParam(method == "uah" || method == "umbmark", "method",
                        "must be uah or umbmark, got '" + method + "'");
  ros_layer::checkParam(after_stage.empty() || after_stage == "camera" || after_stage == "wheels",
                        "after_stage",
                        "must be empty, camera or wheels, got '" + after_stage + "'");
  ros_layer::checkParam(std::isfinite(after_stage_wait_s) && after_stage_wait_s >= 0,
                        "after_stage_wait_s", "must be >= 0 [s]");
  UahRunOptions r = run;
  r.nominal = DiffDriveParams::fromWheel(2 * wheel_radius_m, 100, wheelbase_m);  // set later
  ros_layer::validateParams(r);
  UmbmarkRunOptions u = umbmark;
  u.nominal = r.nominal;
  ros_layer::validateParams(u);
}

namespace {

OdometryCalibrationNodeOptions readOptions(const ros::NodeHandle& nh, const ros::NodeHandle& pnh) {
  const ros_layer::ParamReader p(pnh, "odometry_calibration_node");
  OdometryCalibrationNodeOptions o;
  o.veh = ros_layer::defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("resume", o.resume);
  p.get("wheel_radius_m", o.wheel_radius_m);
  p.get("wheelbase_m", o.wheelbase_m);
  p.get("ticks_per_revolution", o.ticks_per_revolution);
  p.get("control_rate_hz", o.control_rate_hz);
  p.get("connect_wait_s", o.connect_wait_s);
  p.get("status_rate_hz", o.status_rate_hz);
  p.get("method", o.method);
  p.get("after_stage", o.after_stage);
  p.get("after_stage_wait_s", o.after_stage_wait_s);
  // Only the chosen method's keys are read (and echoed); the rest keep their defaults.
  if (o.method == "umbmark") {
    UmbmarkRunOptions& u = o.umbmark;
    p.get("side_m", u.side_m);
    p.get("runs_per_direction", u.runs_per_direction);
    std::string expressions = toString(u.expressions);
    p.get("expressions", expressions);
    try {
      u.expressions = umbmarkExpressionsFromName(expressions);
    } catch (const ConfigError&) {
      ros_layer::checkParam(false, "expressions", "must be original or corrected");
    }
    p.get("drive_rate_pulses_per_s", u.drive_rate_pulses_per_s);
    p.get("turn_rate_pulses_per_s", u.turn_rate_pulses_per_s);
    p.get("start_duty", u.start_duty);
    p.get("max_duty", u.max_duty);
    p.get("max_return_error_fraction", u.max_return_error_fraction);
    p.get("stall_s", u.stall_s);
    p.get("encoder_timeout_s", u.encoder_timeout_s);
    p.get("error_timeout_s", u.error_timeout_s);
    p.get("max_duration_s", u.max_duration_s);
    p.get("errors_file", o.errors_file);
    u.errors_after_all = !o.errors_file.empty();
    if (u.errors_after_all) p.get("run_pause_s", u.run_pause_s);
    o.validate();
    return o;
  }
  UahRunOptions& r = o.run;
  p.get("rounds", r.rounds);
  p.get("pivot_experiments", r.pivot_experiments);
  p.get("pivot_rate_pulses_per_s", r.pivot_rate_pulses_per_s);
  p.get("spin_rate_pulses_per_s", r.spin_rate_pulses_per_s);
  p.get("straight_rate_pulses_per_s", r.straight_rate_pulses_per_s);
  p.get("start_duty", r.start_duty);
  p.get("max_duty", r.max_duty);
  p.get("straight_length_m", r.straight_length_m);
  p.get("straight_runs", r.straight_runs);
  p.get("max_straight_retries", r.max_straight_retries);
  p.get("max_heading_deviation_rad", r.straight.max_heading_deviation_rad);
  p.get("min_clearance_m", r.min_clearance_m);
  p.get("window_fraction", r.detection.window_fraction);
  p.get("min_peak_correlation", r.detection.min_peak_correlation);
  p.get("max_secondary_ratio", r.detection.max_secondary_ratio);
  p.get("min_range_spread_m", r.min_range_spread_m);
  p.get("max_invalid_range_fraction", r.max_invalid_range_fraction);
  p.get("stall_s", r.stall_s);
  p.get("encoder_timeout_s", r.encoder_timeout_s);
  p.get("range_timeout_s", r.range_timeout_s);
  p.get("length_timeout_s", r.length_timeout_s);
  p.get("max_duration_s", r.max_duration_s);
  o.validate();
  return o;
}

}  // namespace

OdometryCalibrationNode::OdometryCalibrationNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readOptions(nh, pnh)),
      status_throttle_(options_.status_rate_hz) {
  // The output folder, before the robot moves (the file is written after the last experiment).
  checkWritableFolder(
      std::filesystem::path(odometryCalibrationPath(options_.calibration_root, options_.veh))
          .parent_path()
          .string());
  status_ = ros_layer::StatusPublisher(nh_, "calibration/status");
  status_.running("odometry/wait", 0, "waiting for the encoders and the range sensor");
}

void OdometryCalibrationNode::start(int ticks_per_revolution) {
  UahRunOptions r = options_.run;
  const int resolution =
      options_.ticks_per_revolution > 0 ? options_.ticks_per_revolution : ticks_per_revolution;
  r.nominal =
      DiffDriveParams::fromWheel(2 * options_.wheel_radius_m, resolution, options_.wheelbase_m);
  if (umbmark()) {
    UmbmarkRunOptions u = options_.umbmark;
    u.nominal = r.nominal;
    const std::string errors = options_.errors_file.empty()
                                   ? "on ~return_error after each square"
                                   : "from " + options_.errors_file + " after all squares";
    ROS_INFO(
        "odometry_calibration_node: UMBmark: nominal radius %.4f m, wheelbase %.4f m, %d "
        "ticks/rev; "
        "%d squares of %.2f m each way (%s expressions), return errors %s; calibration root %s",
        options_.wheel_radius_m, options_.wheelbase_m, resolution, u.runs_per_direction, u.side_m,
        toString(u.expressions).c_str(), errors.c_str(), options_.calibration_root.c_str());
    umbmark_run_ = std::make_unique<UmbmarkRun>(u);
    return;
  }
  ROS_INFO(
      "odometry_calibration_node: nominal radius %.4f m, wheelbase %.4f m, %d ticks/rev; %d rounds "
      "x %d pivot experiments per wheel, spin, %d straight runs of %.2f m (heading within %.2f "
      "deg, up to %d retries); calibration root %s",
      options_.wheel_radius_m, options_.wheelbase_m, resolution, r.rounds, r.pivot_experiments,
      r.straight_runs, r.straight_length_m, r.straight.max_heading_deviation_rad * 180 / M_PI,
      r.max_straight_retries, options_.calibration_root.c_str());
  run_ = std::make_unique<UahRun>(r);
}

void OdometryCalibrationNode::publishStatus(bool force) {
  const std::string phase = std::string("odometry/") + name(run_->experiment());
  const std::string key = phase + "/" + std::to_string(run_->round()) + "/" +
                          std::to_string(run_->straightRun()) + "/" +
                          std::to_string(run_->needsStraightLength());
  // Every change of experiment, round, straight run or waiting is published at once (a helper
  // or a person acts on it); the rest at status_rate_hz.
  if (!status_throttle_.due(key, ros::Time::now().toSec(), force)) return;
  if (status_throttle_.keyChanged())
    ROS_INFO("odometry_calibration_node: %s", run_->describe().c_str());
  status_.running(phase, run_->progress(), run_->describe(),
                  {{"round", static_cast<double>(run_->round())},
                   {"pulses_per_round", run_->pulsesPerRound()},
                   {"straight_run", static_cast<double>(run_->straightRun())},
                   {"awaiting_length", run_->needsStraightLength() ? 1.0 : 0.0},
                   {"run_start_s", run_->straightRunStartS()},
                   {"elapsed_s", run_->elapsedS()}});
}

void OdometryCalibrationNode::run() {
  if (options_.resume &&
      ros_layer::resumeStage(status_, options_.calibration_root, options_.veh, "odometry"))
    return;
  if (!options_.after_stage.empty()) {
    status_.running("odometry/wait", 0, "waiting for the " + options_.after_stage + " stage");
    ROS_INFO("odometry_calibration_node: waiting for the %s stage's DONE on %s",
             options_.after_stage.c_str(), status_.topic().c_str());
    ros_layer::waitForStage(nh_, options_.after_stage, options_.after_stage_wait_s);  // throws
    if (!ros_layer::ok()) return;
  }
  encoders_ = std::make_unique<ros_layer::EncoderInput>(
      nh_,
      [this](const ros::Time& stamp, int left, int right, int resolution) {
        if (!run_ && !umbmark_run_) start(resolution);
        if (umbmark_run_) {
          umbmark_run_->addEncoders(stamp.toSec(), left, right);
        } else {
          run_->addEncoders(stamp.toSec(), left, right);
        }
      },
      &error_);
  range_sub_ = nh_.subscribe<sensor_msgs::Range>(
      "front_center_tof_driver_node/range", 20, [this](const sensor_msgs::Range::ConstPtr& msg) {
        if (!run_) return;
        const RangeReading r = ros_layer::fromRangeMsg(*msg);
        run_->addRange(r.stamp_s, r.range_m);
      });
  error_sub_ = pnh_.subscribe<geometry_msgs::Point>(
      "return_error", 5, [this](const geometry_msgs::Point::ConstPtr& msg) {
        if (!umbmark_run_ || !umbmark_run_->needsReturnError()) {
          ROS_WARN(
              "odometry_calibration_node: a return error (%.4f, %.4f) m arrived while no UMBmark "
              "square waits for one: ignored",
              msg->x, msg->y);
          return;
        }
        const std::string which = std::string(name(umbmark_run_->phase())) + " run " +
                                  std::to_string(umbmark_run_->runInDirection());
        try {
          umbmark_run_->setReturnError({msg->x, msg->y});
        } catch (...) {
          error_ = std::current_exception();
          return;
        }
        ROS_INFO("odometry_calibration_node: %s: return error (%.4f, %.4f) m", which.c_str(),
                 msg->x, msg->y);
      });
  length_sub_ = pnh_.subscribe<std_msgs::Float64>(
      "straight_length", 5, [this](const std_msgs::Float64::ConstPtr& msg) {
        if (!run_ || !run_->needsStraightLength()) {
          ROS_WARN(
              "odometry_calibration_node: a straight length (%.4f m) arrived while no run "
              "waits for one: ignored",
              msg->data);
          return;
        }
        const int run = run_->straightRun();
        try {
          run_->setStraightLength(msg->data);
        } catch (...) {
          error_ = std::current_exception();
          return;
        }
        const StraightRun& last = run_->straightRuns().back();
        ROS_INFO(
            "odometry_calibration_node: straight run %d: %.4f m given, %.0f right pulses, "
            "heading deviated %.2f deg (%s)",
            run, last.length_m, last.right_pulses, last.max_heading_deviation_rad * 180 / M_PI,
            last.max_heading_deviation_rad <= options_.run.straight.max_heading_deviation_rad
                ? "accepted"
                : "rejected");
      });
  wheels_ = ros_layer::connectStage(
      nh_,
      [this] { return encoders_->connected() && (umbmark() || range_sub_.getNumPublishers() > 0); },
      options_.connect_wait_s);
  ros::Rate rate(options_.control_rate_hz);
  const ros::WallTime wait_start = ros::WallTime::now();
  while (ros_layer::ok() && !runDone()) {
    ros::spinOnce();
    if (error_) std::rethrow_exception(error_);
    if (!run_ && !umbmark_run_) {
      const double encoder_timeout_s =
          umbmark() ? options_.umbmark.encoder_timeout_s : options_.run.encoder_timeout_s;
      if ((ros::WallTime::now() - wait_start).toSec() >
          encoder_timeout_s + options_.connect_wait_s) {
        throw InputError("no encoder readings on left/right_wheel_encoder_node/tick");
      }
      wheels_.command(0, 0);
      // Wall time until the first reading: the clock may be held until a command arrives.
      ros::WallDuration(1.0 / options_.control_rate_hz).sleep();
      continue;
    }
    if (umbmark_run_) {
      pollErrorsFile();
      if (umbmark_run_->done()) break;
      const WheelDuties duties = umbmark_run_->update(ros::Time::now().toSec());
      wheels_.command(duties.left, duties.right);
      publishUmbmarkStatus(false);
    } else {
      const WheelDuties duties = run_->update(ros::Time::now().toSec());
      wheels_.command(duties.left, duties.right);
      publishStatus(false);
    }
    rate.sleep();
  }
  if (!ros_layer::ok()) return;  // interrupted: runNode stops the wheels
  wheels_.stop();
  if (umbmark_run_) {
    finishUmbmark();
  } else {
    finish();
  }
}

void OdometryCalibrationNode::pollErrorsFile() {
  if (!umbmark_run_->needsAllReturnErrors()) return;
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_file_poll_).toSec() < 1.0) return;
  last_file_poll_ = now;
  // The person writes the file once every square is measured: until it reads whole with every
  // square's error, wait (a half-written file is read again a second later).
  std::vector<ReturnError> cw, ccw;
  try {
    loadUmbmarkErrors(options_.errors_file, &cw, &ccw);
  } catch (const Error& e) {
    ROS_WARN_THROTTLE(30, "odometry_calibration_node: waiting for the return errors in %s: %s",
                      options_.errors_file.c_str(), e.what());
    return;
  }
  const size_t n = static_cast<size_t>(options_.umbmark.runs_per_direction);
  if (cw.size() != n || ccw.size() != n) {
    ROS_WARN_THROTTLE(30,
                      "odometry_calibration_node: %s holds %zu cw and %zu ccw errors, waiting "
                      "for %zu of each",
                      options_.errors_file.c_str(), cw.size(), ccw.size(), n);
    return;
  }
  ROS_INFO("odometry_calibration_node: read %zu + %zu return errors from %s", cw.size(), ccw.size(),
           options_.errors_file.c_str());
  umbmark_run_->setReturnErrors(cw, ccw);
}

void OdometryCalibrationNode::publishUmbmarkStatus(bool force) {
  const UmbmarkRun& u = *umbmark_run_;
  const std::string phase = std::string("odometry/") + name(u.phase());
  const int run_index = static_cast<int>(
      u.clockwiseErrors().size() + u.counterClockwiseErrors().size() + u.computedEnds().size());
  const std::string key = phase + "/" + std::to_string(u.runInDirection()) + "/" +
                          std::to_string(u.leg()) + "/" + std::to_string(u.needsReturnError()) +
                          "/" + std::to_string(u.needsAllReturnErrors()) + "/" +
                          std::to_string(run_index);
  // Every change of square, leg or waiting is published at once (a helper or a person acts on
  // it); the rest at status_rate_hz.
  if (!status_throttle_.due(key, ros::Time::now().toSec(), force)) return;
  if (status_throttle_.keyChanged())
    ROS_INFO("odometry_calibration_node: %s", u.describe().c_str());
  status_.running(phase, u.progress(), u.describe(),
                  {{"run", static_cast<double>(u.runInDirection())},
                   {"leg", static_cast<double>(u.leg())},
                   {"squares_driven", static_cast<double>(u.computedEnds().size())},
                   {"awaiting_error", u.needsReturnError() ? 1.0 : 0.0},
                   {"awaiting_errors_file", u.needsAllReturnErrors() ? 1.0 : 0.0},
                   {"run_start_s", u.runStartS()},
                   {"computed_x_m", u.computedPose().x_m},
                   {"computed_y_m", u.computedPose().y_m},
                   {"elapsed_s", u.elapsedS()}});
}

void OdometryCalibrationNode::finishUmbmark() {
  const UmbmarkResult& r = umbmark_run_->result();
  UmbmarkOptions umbmark_options = options_.umbmark.umbmark();
  umbmark_options.wheelbase_m = options_.wheelbase_m;
  const OdometryCalibration calibration =
      toOdometryCalibration(r, umbmark_options, options_.veh,
                            options_.errors_file.empty() ? "~return_error" : options_.errors_file);
  const std::string path = odometryCalibrationPath(options_.calibration_root, options_.veh);
  status_.running("odometry/write", 0.99, umbmark_run_->describe());
  writeOdometryCalibration(path, calibration);  // the quality gate first; throws on failure
  ROS_INFO(
      "odometry_calibration_node: wrote %s: UMBmark (%s expressions) Ed %.5f, Eb %.5f (wheelbase "
      "%.5f m), c_L x%.5f, c_R x%.5f, E_max,syst %.1f mm, %.1f s",
      path.c_str(), calibration.expressions.c_str(), calibration.Ed, calibration.Eb,
      calibration.wheelbase_m, calibration.left_pulse_factor, calibration.right_pulse_factor,
      1000 * r.E_max_syst_m, umbmark_run_->elapsedS());
  status_.wrote("odometry/write", path,
                {{"Ed", calibration.Ed},
                 {"Eb", calibration.Eb},
                 {"wheelbase_m", calibration.wheelbase_m},
                 {"left_pulse_factor", calibration.left_pulse_factor},
                 {"right_pulse_factor", calibration.right_pulse_factor},
                 {"E_max_syst_m", r.E_max_syst_m},
                 {"runs_cw", static_cast<double>(r.runs_cw)},
                 {"runs_ccw", static_cast<double>(r.runs_ccw)},
                 {"elapsed_s", umbmark_run_->elapsedS()}});
}

void OdometryCalibrationNode::finish() {
  const UahResult& r = run_->result();
  const OdometryCalibration calibration = r.toOdometryCalibration(options_.veh);
  const std::string path = odometryCalibrationPath(options_.calibration_root, options_.veh);
  status_.running("odometry/write", 0.99, run_->describe());
  writeOdometryCalibration(path, calibration);  // the quality gate first; throws on failure
  ROS_INFO(
      "odometry_calibration_node: wrote %s: Ed %.5f, wheelbase %.5f m (Eb %.4f), c_L %.5f mm, "
      "c_R %.5f mm per pulse, %.1f s",
      path.c_str(), calibration.Ed, calibration.wheelbase_m, calibration.Eb,
      1000 * calibration.left_m_per_pulse, 1000 * calibration.right_m_per_pulse, run_->elapsedS());
  double spin_ppr = 0;
  for (const auto& t : run_->turns())
    if (t.experiment == UahExperiment::kSpin) spin_ppr = t.detection.pulses_per_round;
  status_.wrote("odometry/write", path,
                {{"Ed", calibration.Ed},
                 {"Eb", calibration.Eb},
                 {"wheelbase_m", calibration.wheelbase_m},
                 {"left_m_per_pulse", calibration.left_m_per_pulse},
                 {"right_m_per_pulse", calibration.right_m_per_pulse},
                 {"right_pulses_per_round_left_stopped", r.ed.right_pulses_per_round},
                 {"left_pulses_per_round_right_stopped", r.ed.left_pulses_per_round},
                 {"spin_pulses_per_round", spin_ppr},
                 {"straight_runs_accepted", static_cast<double>(r.straight.accepted_runs.size())},
                 {"elapsed_s", run_->elapsedS()}});
}

}  // namespace odometry
}  // namespace autocal
