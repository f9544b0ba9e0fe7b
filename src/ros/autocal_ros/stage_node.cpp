#include "autocal_ros/stage_node.h"

#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>

#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/format.h"
#include "autocal_ros/msg_conversion.h"

namespace autocal {
namespace ros_layer {

StageNodeOptions readStageNodeOptions(const ParamReader& p, const ros::NodeHandle& nh,
                                      double min_control_rate_hz) {
  StageNodeOptions o;
  o.veh = defaultVeh(nh);
  p.get("veh", o.veh);
  p.get("calibration_root", o.calibration_root);
  p.get("resume", o.resume);
  p.get("control_rate_hz", o.control_rate_hz);
  p.get("connect_wait_s", o.connect_wait_s);
  p.get("status_rate_hz", o.status_rate_hz);
  checkParam(!o.veh.empty() && o.veh.find('/') == std::string::npos, "veh",
             "must be a non-empty name without '/' (the robot's name names the files)");
  checkCalibrationRoot(o.calibration_root);
  checkParam(std::isfinite(o.control_rate_hz) && o.control_rate_hz >= min_control_rate_hz,
             "control_rate_hz", "must be >= " + formatNumber(min_control_rate_hz, 3) + " Hz");
  checkParam(std::isfinite(o.connect_wait_s) && o.connect_wait_s >= 0, "connect_wait_s",
             "must be >= 0");
  checkParam(std::isfinite(o.status_rate_hz) && o.status_rate_hz > 0, "status_rate_hz",
             "must be > 0");
  return o;
}

StageNode::StageNode(ros::NodeHandle nh, std::string node_name, std::string stage,
                     const StageNodeOptions& options, const StageInputs& inputs,
                     const std::string& wait_text)
    : nh_(nh),
      node_name_(std::move(node_name)),
      stage_name_(std::move(stage)),
      options_(options),
      inputs_(inputs),
      status_(nh_, "calibration/status"),
      throttle_(options.status_rate_hz) {
  status_.running(stage_name_ + "/wait", 0, wait_text);
}

bool StageNode::inputsConnected() const {
  return encoders_ && encoders_->connected() && (!frames_ || frames_->publishers() > 0) &&
         (!inputs_.ranges || range_sub_.getNumPublishers() > 0);
}

void StageNode::subscribe(const Hooks& hooks) {
  if (!inputs_.image_transport.empty()) {
    frames_used_ = nh_.advertise<std_msgs::Header>("calibration/frames_used", 50);
    frames_ = std::make_unique<FrameInput>(
        nh_, inputs_.image_transport, node_name_,
        [this](const ros::Time& stamp) {
          if (!stage_) return false;
          arrivals_.frames = true;
          stage_->noteFrameArrived(ros::Time::now().toSec());
          // Decode only the frames the stage wants: the others cost nothing.
          return stage_->wantsFrame(stamp.toSec());
        },
        [this, hooks](const ros::Time& stamp, const cv::Mat& image, const std::string& source) {
          if (stage_->addFrame(stamp.toSec(), image, source)) {
            // For a replay of the recording: the frames this stage took (doc/nodes/replay.md).
            std_msgs::Header used;
            used.stamp = stamp;
            used.frame_id = stage_name_;
            frames_used_.publish(used);
          }
          if (hooks.after_frame) hooks.after_frame(stamp.toSec(), image);
        },
        &error_);
  }
  EncoderInput::WheelHandler on_wheel;
  if (inputs_.pair_encoders) {
    // Each wheel's count with the other's at the same instant: on a robot the two ticks come
    // apart, and a count paired with the other wheel's older one is a turn that did not happen.
    on_wheel = [this](int side, const ros::Time& stamp, std::int32_t ticks, int resolution) {
      for (const EncoderPairer::Pair& p : pairer_.add(side, stamp.toSec(), ticks)) {
        if (!stage_) continue;
        stage_->addEncoders(p.stamp_s, static_cast<int>(std::lround(p.left_ticks)),
                            static_cast<int>(std::lround(p.right_ticks)), resolution,
                            ros::Time::now().toSec());
      }
    };
  }
  encoders_ = std::make_unique<EncoderInput>(
      nh_,
      [this](const ros::Time& stamp, int left, int right, int resolution) {
        arrivals_.encoders = true;
        if (inputs_.pair_encoders || !stage_) return;
        stage_->addEncoders(stamp.toSec(), left, right, resolution, ros::Time::now().toSec());
      },
      &error_, on_wheel, inputs_.queue_size);
  if (inputs_.ranges) {
    range_sub_ = nh_.subscribe<sensor_msgs::Range>("front_center_tof_driver_node/range", 20,
                                                   [this](const sensor_msgs::Range::ConstPtr& msg) {
                                                     if (!stage_) return;
                                                     const RangeReading r = fromRangeMsg(*msg);
                                                     try {
                                                       stage_->addRange(r.stamp_s, r.range_m);
                                                     } catch (...) {
                                                       if (!error_)
                                                         error_ = std::current_exception();
                                                     }
                                                   });
  }
}

void StageNode::build(const Factory& factory, int ticks_per_revolution) {
  stage_ = factory(ticks_per_revolution);
  if (encoders_->valid() && !inputs_.pair_encoders) {
    // The latest reading, so that the stage starts from where the wheels are.
    const double now = ros::Time::now().toSec();
    stage_->addEncoders(now, encoders_->left(), encoders_->right(), encoders_->resolution(), now);
  }
}

void StageNode::publishStatus() {
  const StageStatus s = stage_->status();
  const std::string phase = stage_name_ + "/" + s.step;
  // Every change of what a watcher acts on is published at once; the rest at status_rate_hz.
  if (!throttle_.due(s.key.empty() ? phase : phase + "/" + s.key, ros::Time::now().toSec())) return;
  if (throttle_.keyChanged())
    ROS_INFO("%s: %s: %s", node_name_.c_str(), phase.c_str(), s.text.c_str());
  Figures figures = s.figures;
  if (frames_) figures.emplace_back("frames_dropped", static_cast<double>(frames_->dropped()));
  status_.running(phase, s.progress, s.text, figures);
}

bool StageNode::resumed() {
  return options_.resume &&
         resumeStage(status_, options_.calibration_root, options_.veh, stage_name_);
}

void StageNode::run(const Factory& factory, const Hooks& hooks) {
  if (resumed()) return;
  if (!options_.after_stage.empty()) {
    status_.running(stage_name_ + "/wait", 0, "waiting for the " + options_.after_stage + " stage");
    ROS_INFO("%s: waiting for the %s stage's DONE on %s", node_name_.c_str(),
             options_.after_stage.c_str(), status_.topic().c_str());
    after_stage_done_ = waitForStage(nh_, options_.after_stage, options_.after_stage_wait_s);
    if (!ok()) return;
  }
  subscribe(hooks);
  wheels_ = connectStage(
      nh_, [this] { return inputsConnected(); }, options_.connect_wait_s);
  if (hooks.before_build) hooks.before_build();
  if (!ok()) return;
  if (inputs_.first_encoders_wait_s <= 0) {
    build(factory, encoders_->valid() ? encoders_->resolution() : 0);
  } else {
    // Wall time until the first reading: a simulator may hold its clock until a command arrives.
    const ros::WallTime end =
        ros::WallTime::now() + ros::WallDuration(inputs_.first_encoders_wait_s);
    while (ok() && !encoders_->valid()) {
      ros::spinOnce();
      if (error_) std::rethrow_exception(error_);
      if (ros::WallTime::now() > end)
        throw InputError("no encoder readings on left/right_wheel_encoder_node/tick");
      wheels_.command(0, 0);
      ros::WallDuration(1.0 / options_.control_rate_hz).sleep();
    }
    if (!ok()) return;
    build(factory, encoders_->resolution());
  }
  Stage& stage = *stage_;
  if (!runStageLoop(
          stage, [&] { return stage.done(); }, options_.control_rate_hz, error_, arrivals_, wheels_,
          [this] { publishStatus(); }))
    return;  // interrupted: runNode stops the wheels
  finish(hooks);
}

void StageNode::finish(const Hooks& hooks) {
  Stage& stage = *stage_;
  status_.running(stage_name_ + "/" + stage.finishStep(), 0.98, stage.status().text);
  StageResult result = stage.finish({options_.calibration_root, options_.veh});
  if (frames_)
    result.figures.emplace_back("frames_dropped", static_cast<double>(frames_->dropped()));
  if (hooks.after_finish) hooks.after_finish(result);
  ROS_INFO("%s: wrote %s: %s", node_name_.c_str(), result.file.c_str(), result.log.c_str());
  status_.done(stage_name_ + "/write", result.text.empty() ? "wrote " + result.file : result.text,
               result.figures, result.file);
}

bool StageNode::hand(const std::string& what, bool awaited, const std::function<void()>& give) {
  if (!awaited) {
    ROS_WARN("%s: %s arrived while none is awaited: ignored", node_name_.c_str(), what.c_str());
    return false;
  }
  try {
    give();
  } catch (...) {
    error_ = std::current_exception();
    return false;
  }
  return true;
}

}  // namespace ros_layer
}  // namespace autocal
