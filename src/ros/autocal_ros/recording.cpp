#include "autocal_ros/recording.h"

#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>
#include <sys/stat.h>

#include <algorithm>

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

}  // namespace ros_layer
}  // namespace autocal
