// What the ROS 1 and rosbag2 readers share: the decoded messages they hand over, the topic
// choice, and the one step that turns the messages into a Recording.
#pragma once

#include <stend/io/rosbag.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

namespace stend::io::rosbag_detail {

struct ImuMessage {
  std::int64_t stamp_ns = 0;   // header.stamp
  std::int64_t record_ns = 0;  // when the recorder received it (bag time)
  std::string frame_id;
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();  // linear_acceleration
  Eigen::Vector3d gyro_radps = Eigen::Vector3d::Zero();  // angular_velocity
};

struct TemperatureMessage {
  std::int64_t stamp_ns = 0;
  std::int64_t record_ns = 0;
  double celsius = 0.0;
};

struct TopicInfo {
  std::string name;
  std::string type;  // "sensor_msgs/Imu" (ROS 1), "sensor_msgs/msg/Imu" (ROS 2)
};

// Topics in order of first appearance, each name once with the type it first came with. Names are
// looked up in a set beside the list: a crafted bag's many topics cost one lookup each, not a scan
// of the list (quadratic in the bag's size).
class TopicList {
 public:
  void add(const std::string& name, const std::string& type) {
    if (names_.insert(name).second) list_.push_back({name, type});
  }
  const std::vector<TopicInfo>& all() const { return list_; }

 private:
  std::vector<TopicInfo> list_;
  std::unordered_set<std::string> names_;
};

// The type names of one ROS generation.
struct MessageTypes {
  std::string_view imu;
  std::string_view temperature;
};
inline constexpr MessageTypes kRos1Types{"sensor_msgs/Imu", "sensor_msgs/Temperature"};
inline constexpr MessageTypes kRos2Types{"sensor_msgs/msg/Imu", "sensor_msgs/msg/Temperature"};

// The messages of one topic in the bag's order, pulled one at a time.
template <class Message>
class MessageCursor {
 public:
  virtual ~MessageCursor() = default;
  // The next message into m; false after the last one.
  virtual bool next(Message& m) = 0;
};

// What a reader hands over: the chosen topics' messages, each read anew (from the first message)
// by every call, so that an import passes over the bag twice instead of holding it.
class BagReader {
 public:
  virtual ~BagReader() = default;
  virtual std::unique_ptr<MessageCursor<ImuMessage>> imu() const = 0;
  // nullptr without a temperature topic.
  virtual std::unique_ptr<MessageCursor<TemperatureMessage>> temperature() const = 0;
  std::string format;  // "ROS 1 bag v2.0", "rosbag2"
  std::string imu_topic;
  std::vector<std::string> notes;  // what the reader read (files, compression), for the info event
};

// An LZ4 frame (what MCAP's "lz4" chunks and ROS 1's roslz4 chunks hold) decompressed into
// exactly `size` bytes at `out`; empty, or why not.
std::string decompress_lz4_frame(const std::uint8_t* in, std::uint64_t in_size, std::uint8_t* out, std::uint64_t size);

// The Imu topic the options name, or the bag's only Imu topic. Throws ImportError naming the
// bag's topics when the named topic is absent or not Imu, or when there are none or several.
std::string choose_imu_topic(const std::filesystem::path& file, const std::vector<TopicInfo>& topics,
                             const RosbagOptions& options, const MessageTypes& types);
// Throws ImportError when options.temperature_topic is set but absent or not Temperature.
void check_temperature_topic(const std::filesystem::path& file, const std::vector<TopicInfo>& topics,
                             const RosbagOptions& options, const MessageTypes& types);

// The recording of rosbag.hpp's header comment, its samples passed to `out` a chunk at a time: a
// first pass over the messages finds the time base, the first stamp and the frame ids, the second
// converts them. The temperature is held from a second cursor running alongside the Imu one (both
// in time order; else the Temperature messages are held in memory, sorted). Throws ImportError
// when there is no message.
void stream_recording(const std::filesystem::path& file, const BagReader& bag, const RosbagOptions& options,
                      Recording& rec, SampleSink& out);

}  // namespace stend::io::rosbag_detail
