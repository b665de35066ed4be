// ROS 1 bags (format v2.0) through Debian's librosbag storage library (rosbag::Bag, rosbag::View):
// it reads the records, connections, chunks (bz2 / lz4) and the index; this file turns the raw
// sensor_msgs/Imu and sensor_msgs/Temperature messages into a Recording. The messages are
// decoded from their ROS 1 serialization with ros::serialization::IStream (the generated
// sensor_msgs C++ headers do not compile as C++20: their allocator rebind was removed).
#include <stend/io/rosbag.hpp>

#include "import_common.hpp"
#include "rosbag_common.hpp"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <ros/exception.h>
#include <ros/serialization.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace rosbag_detail;

namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
// The message definitions' MD5 sums (sensor_msgs 1.13): a connection of that type name with
// another sum carries another layout.
constexpr char kImuMd5[] = "6a62c6daae103f4ff57a132d6f95cec2";
constexpr char kTemperatureMd5[] = "ff71b307acdbe7c871a5a6d7ed359100";

using Bytes = std::vector<std::uint8_t>;

Bytes serialized(const rosbag::MessageInstance& m) {
  Bytes buf(m.size());
  ros::serialization::OStream out(buf.data(), static_cast<std::uint32_t>(buf.size()));
  m.write(out);
  return buf;
}

std::int64_t stamp_ns(std::uint32_t sec, std::uint32_t nsec) {
  return static_cast<std::int64_t>(sec) * 1000000000 + static_cast<std::int64_t>(nsec);
}

// std_msgs/Header: seq, stamp (sec, nsec), frame_id.
void read_header(ros::serialization::IStream& in, std::int64_t& stamp, std::string& frame_id) {
  std::uint32_t seq = 0, sec = 0, nsec = 0;
  in.next(seq);
  in.next(sec);
  in.next(nsec);
  in.next(frame_id);
  stamp = stamp_ns(sec, nsec);
}

Eigen::Vector3d read_vector3(ros::serialization::IStream& in) {
  Eigen::Vector3d v;
  in.next(v.x());
  in.next(v.y());
  in.next(v.z());
  return v;
}

void skip_doubles(ros::serialization::IStream& in, int n) {
  double ignored = 0.0;
  for (int i = 0; i < n; ++i) in.next(ignored);
}

// sensor_msgs/Imu: header, orientation (4), its covariance (9), angular_velocity (3), covariance
// (9), linear_acceleration (3), covariance (9).
ImuMessage decode_imu(Bytes buf, std::int64_t record_ns) {
  ros::serialization::IStream in(buf.data(), static_cast<std::uint32_t>(buf.size()));
  ImuMessage m;
  m.record_ns = record_ns;
  read_header(in, m.stamp_ns, m.frame_id);
  skip_doubles(in, 4 + 9);
  m.gyro_radps = read_vector3(in);
  skip_doubles(in, 9);
  m.accel_mps2 = read_vector3(in);
  skip_doubles(in, 9);
  return m;
}

// sensor_msgs/Temperature: header, temperature [°C], variance.
TemperatureMessage decode_temperature(Bytes buf, std::int64_t record_ns) {
  ros::serialization::IStream in(buf.data(), static_cast<std::uint32_t>(buf.size()));
  TemperatureMessage m;
  m.record_ns = record_ns;
  std::string frame_id;
  read_header(in, m.stamp_ns, frame_id);
  in.next(m.celsius);
  return m;
}

std::vector<TopicInfo> bag_topics(const rosbag::Bag& bag) {
  std::vector<TopicInfo> topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections()) {
    bool seen = false;
    for (const TopicInfo& t : topics) seen = seen || t.name == c->topic;
    if (!seen) topics.push_back({c->topic, c->datatype});
  }
  return topics;
}

void check_md5(const fs::path& file, const rosbag::MessageInstance& m, const char* md5) {
  if (m.getMD5Sum() != md5) {
    throw ImportError(file, "topic " + m.getTopic(),
                      m.getDataType() + " with definition MD5 " + m.getMD5Sum() + ", expected " + md5 +
                          " (sensor_msgs as released with ROS 1)");
  }
}

// The messages of one topic through a librosbag View (which reads the chunks as it goes).
template <class Message>
class ViewCursor final : public MessageCursor<Message> {
 public:
  using Decode = Message (*)(Bytes, std::int64_t);
  ViewCursor(const fs::path& file, const rosbag::Bag& bag, const std::string& topic, const char* md5, Decode decode)
      : file_(file), view_(bag, rosbag::TopicQuery(topic)), it_(view_.begin()), md5_(md5), decode_(decode) {}
  bool next(Message& out) override {
    if (it_ == view_.end()) return false;
    const rosbag::MessageInstance& m = *it_;
    ++index_;
    try {
      check_md5(file_, m, md5_);
      out = decode_(serialized(m), static_cast<std::int64_t>(m.getTime().toNSec()));
    } catch (const ros::serialization::StreamOverrunException& e) {
      throw ImportError(file_, "message " + std::to_string(index_) + " of topic " + m.getTopic(),
                        std::string("message shorter than its type: ") + e.what());
    }
    ++it_;
    return true;
  }

 private:
  fs::path file_;
  rosbag::View view_;
  rosbag::View::iterator it_;
  const char* md5_;
  Decode decode_;
  std::size_t index_ = 0;
};

class Ros1Reader final : public BagReader {
 public:
  Ros1Reader(const fs::path& file, const rosbag::Bag& bag, const std::string& topic, std::string temperature_topic)
      : file_(file), bag_(bag), temperature_topic_(std::move(temperature_topic)) {
    format = "ROS 1 bag v2.0";
    imu_topic = topic;
  }
  std::unique_ptr<MessageCursor<ImuMessage>> imu() const override {
    return std::make_unique<ViewCursor<ImuMessage>>(file_, bag_, imu_topic, kImuMd5, decode_imu);
  }
  std::unique_ptr<MessageCursor<TemperatureMessage>> temperature() const override {
    if (temperature_topic_.empty()) return nullptr;
    return std::make_unique<ViewCursor<TemperatureMessage>>(file_, bag_, temperature_topic_, kTemperatureMd5,
                                                            decode_temperature);
  }

 private:
  fs::path file_;
  const rosbag::Bag& bag_;
  std::string temperature_topic_;
};

// The bag header record's index_pos (where librosbag reads the connection and chunk index
// from), or 0 when the header cannot be read. Record: uint32 header length, fields
// (uint32 length, "name=value"), uint32 data length, data.
std::uint64_t index_position(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  in.seekg(sizeof kMagic - 1);
  auto u32 = [&in] {
    std::uint8_t b[4] = {};
    in.read(reinterpret_cast<char*>(b), 4);
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24);
  };
  const std::uint32_t header_len = u32();
  if (!in || header_len > 4096) return 0;
  std::string header(header_len, '\0');
  in.read(header.data(), header_len);
  if (!in) return 0;
  constexpr std::string_view kField = "index_pos=";
  for (std::size_t pos = 0; pos + 4 <= header.size();) {
    std::uint32_t n = 0;
    std::memcpy(&n, header.data() + pos, 4);  // little endian, as the host
    const std::string_view field(header.data() + pos + 4, std::min<std::size_t>(n, header.size() - pos - 4));
    if (field.substr(0, kField.size()) == kField && field.size() == kField.size() + 8) {
      std::uint64_t v = 0;
      std::memcpy(&v, field.data() + kField.size(), 8);
      return v;
    }
    pos += 4 + n;
  }
  return 0;
}

// Refuses a bag any record of which librosbag would read at open time lies beyond its bounds,
// before librosbag allocates or parses it. A bag is a sequence of records from the file header
// record to the end — uint32 header length, header (fields: uint32 length, "name=value"), uint32
// data length, data — and its index (the records from index_pos on) points back into it: every
// chunk info's chunk_pos must be where a record starts, and a chunk must be able to hold the
// uncompressed size it declares (librosbag allocates that size to decompress it). The records of a
// bag whose index_pos is not inside the file are left to open_failed, which says why.
void check_record_lengths(const fs::path& path) {
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  const std::uint64_t index = index_position(path);
  if (ec) return;
  std::ifstream in(path, std::ios::binary);
  // `what` reaches past `end` (the end of the file, or of the record's header).
  auto fail = [&](std::uint64_t at, const std::string& what, std::uint64_t end, const char* region = "record header") {
    throw ImportError(path, "byte " + std::to_string(at),
                      what + ", past the end of the " + (end == size ? "file" : region) + " at byte " +
                          std::to_string(end) + " (truncated or damaged)");
  };
  auto u32_at = [&](std::uint64_t at, std::uint64_t end, const char* what, const char* region = "record header") {
    std::uint8_t b[4] = {};
    in.seekg(static_cast<std::streamoff>(at));
    if (end < at + 4 || !in.read(reinterpret_cast<char*>(b), 4))
      fail(at, std::string(what) + " length cut off", end, region);
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24);
  };
  struct Record {
    std::uint64_t pos, data_pos, data_len, next;
    std::string op, compression;
    std::uint64_t chunk_pos = 0, size = 0;  // a chunk info's chunk_pos, a chunk's uncompressed size
  };
  // The value of one header field (at most 8 bytes: the fields read here).
  auto field_value = [&](std::uint64_t at, std::uint32_t n, std::size_t name_len) {
    std::string v(std::min<std::size_t>(n - name_len, 8), '\0');
    in.seekg(static_cast<std::streamoff>(at + 4 + name_len));
    in.read(v.data(), static_cast<std::streamsize>(v.size()));
    return v;
  };
  auto little_endian = [](const std::string& v) {
    std::uint64_t x = 0;
    for (std::size_t i = v.size(); i-- > 0;) x = x << 8 | static_cast<std::uint8_t>(v[i]);
    return x;
  };
  // Calls f(at, length) for each field of the header [begin, end) — uint32 length, "name=value" —
  // after checking that the field lies inside it.
  auto for_each_field = [&](std::uint64_t begin, std::uint64_t end, const char* region, const auto& f) {
    for (std::uint64_t at = begin; at < end;) {
      const std::uint32_t field = u32_at(at, end, "header field", region);
      if (field > end - at - 4) fail(at, "a header field declares " + std::to_string(field) + " bytes", end, region);
      f(at, field);
      at += 4 + field;
    }
  };
  // One record at `pos`: its header's fields and its data inside the file.
  auto record = [&](std::uint64_t pos) {
    const std::uint32_t header = u32_at(pos, size, "record header");
    if (header > size - pos - 4) fail(pos, "a record's header declares " + std::to_string(header) + " bytes", size);
    Record r{pos, 0, 0, 0, {}, {}};
    const std::uint64_t end = pos + 4 + header;
    for_each_field(pos + 4, end, "record header", [&](std::uint64_t at, std::uint32_t field) {
      std::string name(std::min<std::uint32_t>(field, 16), '\0');
      in.read(name.data(), static_cast<std::streamsize>(name.size()));
      name.resize(std::min(name.find('='), name.size()));
      auto value = [&] { return field_value(at, field, name.size() + 1); };
      if (name.size() < field) {
        if (name == "op") r.op = value().substr(0, 1);
        else if (name == "compression") r.compression = value();
        else if (name == "chunk_pos") r.chunk_pos = little_endian(value());
        else if (name == "size") r.size = little_endian(value().substr(0, 4));
      }
    });
    const std::uint32_t data = u32_at(end, size, "record data");
    if (data > size - end - 4) fail(end, "a record's data declares " + std::to_string(data) + " bytes", size);
    r.data_pos = end + 4;
    r.data_len = data;
    r.next = end + 4 + data;
    // A connection record's data is the connection's own header, parsed by librosbag like one.
    if (r.op == "\x07") for_each_field(r.data_pos, r.next, "connection header", [](std::uint64_t, std::uint32_t) {});
    return r;
  };
  // A chunk's uncompressed size against its stored bytes: equal when stored plainly, at most
  // 255:1 for lz4 (its format's limit), 1032:1 for bz2 (zlib's limit, far beyond any IMU bag's).
  auto check_chunk_size = [&](const Record& r) {
    const std::uint64_t limit = r.compression == "none" ? r.data_len
                                : r.compression == "lz4" ? 255 * r.data_len + 64
                                                         : 1032 * r.data_len + 64;
    if (r.compression == "none" ? r.size != r.data_len : r.size > limit) {
      throw ImportError(path, "byte " + std::to_string(r.pos),
                        "a chunk (" + r.compression + ") declares " + std::to_string(r.size) +
                            " uncompressed bytes, which its " + std::to_string(r.data_len) +
                            " stored bytes cannot hold (damaged chunk header)");
    }
  };
  const Record first = record(sizeof kMagic - 1);  // the file header record
  if (index == 0 || index >= size) return;
  std::vector<std::uint64_t> starts;
  std::vector<std::uint64_t> chunk_positions;
  for (std::uint64_t pos = first.next; pos < size;) {
    const Record r = record(pos);
    starts.push_back(pos);
    if (r.op == "\x05") check_chunk_size(r);
    if (r.op == "\x06" && pos >= index) chunk_positions.push_back(r.chunk_pos);
    pos = r.next;
  }
  for (const std::uint64_t c : chunk_positions) {
    if (!std::binary_search(starts.begin(), starts.end(), c)) {
      throw ImportError(path, "index at byte " + std::to_string(index),
                        "a chunk info points at byte " + std::to_string(c) +
                            ", where no record starts (damaged index; `rosbag reindex` rebuilds it)");
    }
  }
}

// Why librosbag could not open the bag, with the offsets that explain it.
[[noreturn]] void open_failed(const fs::path& path, const std::exception& e) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  const std::uint64_t index = index_position(path);
  if (index >= size) {
    throw ImportError(path, "byte " + std::to_string(index),
                      "the bag header puts the index there, but the file ends at byte " + std::to_string(size) +
                          " (truncated, or unindexed: `rosbag reindex` restores an unindexed bag; librosbag: " +
                          e.what() + ")");
  }
  throw ImportError(path, "index at byte " + std::to_string(index) + " (file size " + std::to_string(size) + ")",
                    std::string("librosbag cannot read the bag header or index: ") + e.what());
}

}  // namespace

bool looks_like_rosbag1(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[sizeof kMagic - 1] = {};
  return in.read(head, sizeof head) && std::memcmp(head, kMagic, sizeof head) == 0;
}

void import_rosbag1(const fs::path& path, const RosbagOptions& options, Recording& rec, SampleSink& out) {
  if (!looks_like_rosbag1(path)) {
    throw ImportError(path, "byte 0", "not a ROS 1 bag: expected the magic line '#ROSBAG V2.0'");
  }
  check_record_lengths(path);
  rosbag::Bag bag;
  try {
    bag.open(path.string(), rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    open_failed(path, e);
  }
  try {
    const std::vector<TopicInfo> topics = bag_topics(bag);
    const std::string topic = choose_imu_topic(path, topics, options, kRos1Types);
    check_temperature_topic(path, topics, options, kRos1Types);
    stream_recording(path, Ros1Reader(path, bag, topic, options.temperature_topic), options, rec, out);
  } catch (const ros::Exception& e) {  // librosbag's (the sink's own errors pass as they are)
    throw ImportError(path, "chunks", std::string("librosbag cannot read a message: ") + e.what());
  }
}

Recording import_rosbag1(const fs::path& path, const RosbagOptions& options) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { import_rosbag1(path, options, rec, out); });
}

}  // namespace stend::io
