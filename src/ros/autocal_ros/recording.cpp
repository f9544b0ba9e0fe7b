#include "autocal_ros/recording.h"

#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Header.h>
#include <sys/stat.h>

#include <algorithm>
#include <functional>
#include <set>

#include "autocal/errors.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "autocal_ros/sensor_inputs.h"

namespace autocal {
namespace ros_layer {

Recording::Recording(const std::string& path) : path_(path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) throw InputError(path + ": no such file");
  try {
    bag_.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagUnindexedException& e) {
    throw InputError(path + ": the bag has no index (truncated, or its recording was killed): " +
                     "`rosbag reindex` it first (" + e.what() + ")");
  } catch (const rosbag::BagException& e) {
    throw InputError(path +
                     ": cannot open the bag (not a bag, truncated or corrupt?): " + e.what());
  }
  rosbag::View all(bag_);
  for (const rosbag::ConnectionInfo* c : all.getConnections()) types_[c->topic] = c->datatype;
  if (all.size() > 0) {
    begin_s_ = all.getBeginTime().toSec();
    end_s_ = all.getEndTime().toSec();
  }
}

void Recording::require(const std::vector<std::string>& topics, const std::string& veh) const {
  std::string missing, listing;
  for (const std::string& t : topics)
    if (!has(t)) missing += (missing.empty() ? "" : ", ") + t;
  if (missing.empty()) return;
  for (const auto& [topic, type] : types_) listing += "\n  " + topic + " (" + type + ")";
  throw InputError(path_ + ": no " + missing + " in the bag (is --veh " + veh +
                   " right?); the bag has:" + (listing.empty() ? " nothing" : listing));
}

std::vector<std::string> Recording::robots() const {
  const std::string suffix = "/calibration/status";
  std::vector<std::string> out;
  for (const auto& entry : types_) {
    const std::string& topic = entry.first;
    if (topic.size() > suffix.size() + 1 && topic[0] == '/' &&
        topic.compare(topic.size() - suffix.size(), suffix.size(), suffix) == 0) {
      const std::string ns = topic.substr(1, topic.size() - suffix.size() - 1);
      if (ns.find('/') == std::string::npos) out.push_back(ns);
    }
  }
  return out;
}

namespace {

/// A header stamp, or the message's record time when the publisher left it 0.
double stampOf(const rosbag::MessageInstance& m, const ros::Time& header_stamp) {
  return (header_stamp.isZero() ? m.getTime() : header_stamp).toSec();
}

}  // namespace

std::map<std::string, std::set<double>> framesUsed(Recording& recording, const std::string& veh) {
  std::map<std::string, std::set<double>> out;
  const std::string topic = "/" + veh + "/calibration/frames_used";
  if (!recording.has(topic)) return out;
  try {
    for (const rosbag::MessageInstance& m :
         rosbag::View(recording.bag(), rosbag::TopicQuery(topic))) {
      const auto msg = m.instantiate<std_msgs::Header>();
      if (!msg)
        throw InputError(recording.path() + ": " + topic + " carries " + m.getDataType() +
                         ", not std_msgs/Header");
      out[msg->frame_id].insert(msg->stamp.toSec());
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(recording.path() +
                     ": the bag cannot be read to its end (truncated or "
                     "corrupt?): " +
                     e.what());
  }
  return out;
}

std::vector<std::string> recordedStages(Recording& recording, const std::string& veh) {
  const std::string topic = "/" + veh + "/calibration/status";
  std::set<std::string> seen;
  if (recording.has(topic)) {
    try {
      for (const rosbag::MessageInstance& m :
           rosbag::View(recording.bag(), rosbag::TopicQuery(topic))) {
        const auto msg = m.instantiate<autocal::CalibrationStatus>();
        if (!msg) continue;  // feedRecording says what is wrong with it
        const std::string stage = msg->phase.substr(0, msg->phase.find('/'));
        if (msg->phase != stage + "/wait") seen.insert(stage);
      }
    } catch (const rosbag::BagException&) {
      // feedRecording says it
    }
  }
  std::vector<std::string> out;
  for (const char* stage : {"camera", "wheels", "odometry"})
    if (seen.count(stage)) out.push_back(stage);
  return out;
}

RecordingFeed feedRecording(Recording& recording, const std::string& veh, replay::RunReplay& replay,
                            double duration_s, const std::function<void(double share)>& progress) {
  const std::string ns = "/" + veh + "/";
  const std::string left = ns + "left_wheel_encoder_node/tick",
                    right = ns + "right_wheel_encoder_node/tick",
                    compressed = ns + "camera_node/image/compressed",
                    raw = ns + "camera_node/image/raw", info = ns + "camera_node/camera_info",
                    cmd = ns + "wheels_driver_node/wheels_cmd", status = ns + "calibration/status";
  const std::string image = recording.has(compressed) ? compressed : raw;
  const std::string path = recording.path();
  auto wrongType = [&](const rosbag::MessageInstance& m, const char* expected) {
    return InputError(path + ": " + m.getTopic() + " carries " + m.getDataType() + ", not " +
                      expected);
  };
  RecordingFeed feed;
  const double begin_s = recording.beginS(), span_s = std::max(recording.endS() - begin_s, 1e-9);
  const double end_s = duration_s > 0 ? begin_s + duration_s : recording.endS();
  double reported = -1;
  rosbag::View view(recording.bag(), rosbag::TopicQuery({left, right, image, info, cmd, status}));
  try {
    for (const rosbag::MessageInstance& m : view) {
      if (m.getTime().toSec() > end_s || replay.ended()) break;
      ++feed.messages;
      feed.end_s = m.getTime().toSec();
      const std::string& topic = m.getTopic();
      if (topic == left || topic == right) {
        const auto msg = m.instantiate<dtmsg::WheelEncoderStamped>();
        if (!msg) throw wrongType(m, "WheelEncoderStamped");
        const EncoderReading r = fromEncoderMsg(*msg);
        replay.addEncoderReading(topic == left ? 0 : 1, stampOf(m, msg->header.stamp), r.ticks,
                                 r.ticks_per_revolution);
      } else if (topic == image) {
        ++feed.frames;
        std::string why;
        cv::Mat gray;
        ros::Time stamp;
        if (topic == compressed) {
          const auto msg = m.instantiate<sensor_msgs::CompressedImage>();
          if (!msg) throw wrongType(m, "sensor_msgs/CompressedImage");
          stamp = msg->header.stamp.isZero() ? m.getTime() : msg->header.stamp;
          if (!replay.wantsFrame(stamp.toSec())) continue;
          gray = decodeFrame(*msg, why);
        } else {
          const auto msg = m.instantiate<sensor_msgs::Image>();
          if (!msg) throw wrongType(m, "sensor_msgs/Image");
          stamp = msg->header.stamp.isZero() ? m.getTime() : msg->header.stamp;
          if (!replay.wantsFrame(stamp.toSec())) continue;
          gray = decodeFrame(*msg, why);
        }
        ++feed.frames_decoded;
        if (gray.empty()) {
          replay.dropFrame();
        } else {
          replay.addFrame(stamp.toSec(), gray,
                          frameSource(topic == compressed ? "compressed" : "raw", stamp));
        }
      } else if (topic == info) {
        const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
        if (!msg) throw wrongType(m, "sensor_msgs/CameraInfo");
        replay.addCameraInfo(fromCameraInfo(*msg));
      } else if (topic == cmd) {
        const auto msg = m.instantiate<dtmsg::WheelsCmdStamped>();
        if (!msg) throw wrongType(m, "WheelsCmdStamped");
        replay.addCommand(stampOf(m, msg->header.stamp), fromWheelsCmd(*msg));
      } else if (topic == status) {
        const auto msg = m.instantiate<autocal::CalibrationStatus>();
        if (!msg) throw wrongType(m, "autocal/CalibrationStatus");
        report::StatusUpdate u = fromStatusMsg(*msg);
        u.stamp_s = stampOf(m, msg->header.stamp);
        replay.addRecordedStatus(u);
      }
      const double share = (m.getTime().toSec() - begin_s) / span_s;
      if (progress && share >= reported + 0.01) {
        reported = share;
        progress(share);
      }
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path +
                     ": the bag cannot be read to its end (truncated or corrupt?): " + e.what());
  }
  replay.endOfRecording();
  return feed;
}

namespace {

/// The messages' times: each message's header stamp; a stamp of 0 is resolved once the whole bag
/// is read (resolve()). A publisher that never stamps leaves 0: its messages take the bag's record
/// time. But a publisher that stamps its other messages sent this one at time 0 of its clock (in
/// the simulator, the clock held at 0 until a controller appears): its record time is when the
/// recorder got it, on a clock already running, and taken as the stamp it put the node's zero
/// commands of time 0 after its first pivot's first command, cutting that motion short
/// (uah_bag.test: "pivot_left_stopped at 0.005 s: the recording has no encoder readings over the
/// motion"). Such a stamp stays 0.
class MessageTimes {
 public:
  /// `header_stamp` [s], and notes it; `slot` is where the caller keeps it (kept until resolve()).
  double note(const rosbag::MessageInstance& m, const ros::Time& header_stamp,
              std::function<double&()> slot) {
    const std::string source = m.getTopic() + " from " + m.getCallerId();
    if (!header_stamp.isZero()) {
      stamping_.insert(source);
    } else {
      zero_.push_back({source, m.getTime().toSec(), std::move(slot)});
    }
    return header_stamp.toSec();
  }
  /// Gives the unstamped messages (those of a publisher that never stamps) their record time.
  void resolve() {
    for (ZeroStamp& z : zero_) {
      if (!stamping_.count(z.source)) z.slot() = z.record_s;
    }
    zero_.clear();
  }

 private:
  struct ZeroStamp {
    std::string source;
    double record_s;
    std::function<double&()> slot;
  };
  std::set<std::string> stamping_;  // topic and publisher of each message with a stamp
  std::vector<ZeroStamp> zero_;
};

}  // namespace

UahBag readUahRecording(Recording& recording, const std::string& veh) {
  const std::string& path = recording.path();
  const std::string ns = "/" + veh + "/";
  const std::string left = ns + "left_wheel_encoder_node/tick",
                    right = ns + "right_wheel_encoder_node/tick",
                    range = ns + "front_center_tof_driver_node/range",
                    cmd = ns + "wheels_driver_node/wheels_cmd", status = ns + "calibration/status",
                    length = ns + "odometry_calibration_node/straight_length";
  recording.require({left, right, range, cmd, status}, veh);
  UahBag out;
  odometry::UahRecording& rec = out.recording;
  struct Tick {
    double stamp_s;
    std::int32_t ticks;
  };
  std::vector<Tick> wheel[2];  // left, right
  rosbag::View view(recording.bag(), rosbag::TopicQuery({left, right, range, cmd, status, length}));
  auto wrongType = [&](const rosbag::MessageInstance& m, const char* expected) {
    return InputError(path + ": " + m.getTopic() + " carries " + m.getDataType() + ", not " +
                      expected);
  };
  MessageTimes times;
  // Where the last message pushed onto `v` keeps its stamp.
  auto lastOf = [](auto& v) {
    return [&v, i = v.size() - 1]() -> double& { return v[i].stamp_s; };
  };
  try {
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == left || topic == right) {
        const auto msg = m.instantiate<dtmsg::WheelEncoderStamped>();
        if (!msg) throw wrongType(m, "WheelEncoderStamped");
        const EncoderReading r = fromEncoderMsg(*msg);
        out.ticks_per_revolution = r.ticks_per_revolution;
        std::vector<Tick>& w = wheel[topic == left ? 0 : 1];
        w.push_back({0, r.ticks});
        w.back().stamp_s = times.note(m, msg->header.stamp, lastOf(w));
      } else if (topic == range) {
        const auto msg = m.instantiate<sensor_msgs::Range>();
        if (!msg) throw wrongType(m, "sensor_msgs/Range");
        const RangeReading r = fromRangeMsg(*msg);
        rec.ranges.push_back({0, r.range_m});
        rec.ranges.back().stamp_s = times.note(m, msg->header.stamp, lastOf(rec.ranges));
      } else if (topic == cmd) {
        const auto msg = m.instantiate<dtmsg::WheelsCmdStamped>();
        if (!msg) throw wrongType(m, "WheelsCmdStamped");
        const WheelDuties d = fromWheelsCmd(*msg);
        rec.commands.push_back({0, d.left, d.right});
        rec.commands.back().stamp_s = times.note(m, msg->header.stamp, lastOf(rec.commands));
      } else if (topic == status) {
        const auto msg = m.instantiate<autocal::CalibrationStatus>();
        if (!msg) throw wrongType(m, "autocal/CalibrationStatus");
        rec.statuses.emplace_back();
        odometry::UahRecording::Status& s = rec.statuses.back();
        s.stamp_s = times.note(m, msg->header.stamp, lastOf(rec.statuses));
        s.phase = msg->phase;
        s.state = msg->state;
        s.failure_reason = msg->failure_reason;
        for (size_t i = 0; i < msg->figure_names.size() && i < msg->figure_values.size(); ++i) {
          if (msg->figure_names[i] == "round") s.round = msg->figure_values[i];
          if (msg->figure_names[i] == "straight_run") s.straight_run = msg->figure_values[i];
        }
      } else if (topic == length) {
        const auto msg = m.instantiate<std_msgs::Float64>();
        if (!msg) throw wrongType(m, "std_msgs/Float64");
        rec.lengths.push_back({m.getTime().toSec(), msg->data});
      }
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path +
                     ": the bag cannot be read to its end (truncated or corrupt?): " + e.what());
  }
  times.resolve();
  // The two wheels' readings in the order of their stamps (the bag holds them in the order the
  // recorder received them, which a loaded machine shuffles): as the node's EncoderInput, every
  // reading, once both wheels reported, is a reading of both (the latest of each); readings of
  // one stamp are merged by replayUah.
  for (auto& w : wheel) {
    std::stable_sort(w.begin(), w.end(),
                     [](const Tick& a, const Tick& b) { return a.stamp_s < b.stamp_s; });
  }
  size_t i = 0, j = 0;
  while (i < wheel[0].size() || j < wheel[1].size()) {
    const bool take_left =
        j >= wheel[1].size() || (i < wheel[0].size() && wheel[0][i].stamp_s <= wheel[1][j].stamp_s);
    const Tick& t = take_left ? wheel[0][i++] : wheel[1][j++];
    if (i == 0 || j == 0) continue;  // until both wheels reported
    rec.encoders.push_back({t.stamp_s, wheel[0][i - 1].ticks, wheel[1][j - 1].ticks});
  }
  if (rec.encoders.empty()) {
    throw InputError(path + ": no reading of both encoders in the bag");
  }
  return out;
}

}  // namespace ros_layer
}  // namespace autocal
