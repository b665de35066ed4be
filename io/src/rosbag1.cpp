// ROS 1 bags (format v2.0), read by Stend itself, every length checked against what holds it:
// the records of the file, the connections and chunk infos of its index, each chunk (stored, bz2
// or lz4) decompressed in turn with the records inside it, and the sensor_msgs/Imu and
// sensor_msgs/Temperature messages of the chosen topics. Memory holds one chunk and the index
// (a few numbers per chunk and per connection), not the messages.
//
// Format (ROS wiki, "Bags/Format/2.0"): the line "#ROSBAG V2.0\n", then records: uint32 header
// length, header fields (uint32 length, "name=value"), uint32 data length, data. The header's op
// field says what a record is: 0x03 bag header (index_pos: where the index starts), 0x05 chunk
// (compression, size: its uncompressed length; data: connection and message records), 0x07
// connection (conn, topic; data: the connection's own header: type, md5sum, …), 0x02 message
// (conn, time: uint32 sec then uint32 nsec; data: the serialized message), 0x04 index data,
// 0x06 chunk info (chunk_pos, start_time, end_time). Numbers are little-endian.
//
// Order: as rosbag's View gives them, by record time. Chunks are read in order of their start
// time and each chunk's messages of the topic sorted by record time (stable), which is that order
// whenever chunks do not overlap in time (rosbag record writes them so); when they do, the
// messages' times and places are gathered first and the messages read in time order through them
// (memory then grows with the messages of the topic, and a note says so).
#include <stend/io/rosbag.hpp>

#include "import_common.hpp"
#include "rosbag_common.hpp"

#include <bzlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
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
constexpr std::uint64_t kMaxStringField = 4096;  // longest header value kept (topic, type, md5sum)

using Bytes = std::vector<std::uint8_t>;

std::uint64_t little_endian(std::string_view v) {
  std::uint64_t x = 0;
  for (std::size_t i = std::min<std::size_t>(v.size(), 8); i-- > 0;) x = x << 8 | static_cast<std::uint8_t>(v[i]);
  return x;
}

// A bag time field (uint32 sec, uint32 nsec) in ns.
std::int64_t time_ns(std::string_view v) {
  const std::uint64_t x = little_endian(v);
  return static_cast<std::int64_t>(x & 0xffffffffu) * 1000000000 + static_cast<std::int64_t>(x >> 32);
}

// ---------------------------------------------------------------------------------------------
// Messages: the ROS 1 serialization (little-endian numbers; a string is uint32 length + bytes).

class MessageReader {
 public:
  MessageReader(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  template <class T>
  T next() {
    T v{};
    take(&v, sizeof v);
    return v;
  }
  std::string string() {
    const auto len = next<std::uint32_t>();
    std::string s(len <= n_ - at_ ? len : 0, '\0');
    take(s.data(), len);
    return s;
  }
  void skip_doubles(int n) { take(nullptr, 8 * static_cast<std::size_t>(n)); }

  struct Overrun {};  // the message is shorter than its type

 private:
  void take(void* out, std::size_t len) {
    if (len > n_ - at_) throw Overrun{};
    if (out) std::memcpy(out, p_ + at_, len);
    at_ += len;
  }
  const std::uint8_t* p_;
  std::size_t n_, at_ = 0;
};

// std_msgs/Header: seq, stamp (sec, nsec), frame_id.
void read_header(MessageReader& in, std::int64_t& stamp, std::string& frame_id) {
  (void)in.next<std::uint32_t>();
  const auto sec = in.next<std::uint32_t>(), nsec = in.next<std::uint32_t>();
  stamp = static_cast<std::int64_t>(sec) * 1000000000 + static_cast<std::int64_t>(nsec);
  frame_id = in.string();
}

Eigen::Vector3d read_vector3(MessageReader& in) {
  const double x = in.next<double>(), y = in.next<double>(), z = in.next<double>();
  return {x, y, z};
}

// sensor_msgs/Imu: header, orientation (4), its covariance (9), angular_velocity (3), covariance
// (9), linear_acceleration (3), covariance (9).
ImuMessage decode_imu(MessageReader in, std::int64_t record_ns) {
  ImuMessage m;
  m.record_ns = record_ns;
  read_header(in, m.stamp_ns, m.frame_id);
  in.skip_doubles(4 + 9);
  m.gyro_radps = read_vector3(in);
  in.skip_doubles(9);
  m.accel_mps2 = read_vector3(in);
  in.skip_doubles(9);
  return m;
}

// sensor_msgs/Temperature: header, temperature [°C], variance.
TemperatureMessage decode_temperature(MessageReader in, std::int64_t record_ns) {
  TemperatureMessage m;
  m.record_ns = record_ns;
  std::string frame_id;
  read_header(in, m.stamp_ns, frame_id);
  m.celsius = in.next<double>();
  return m;
}

// ---------------------------------------------------------------------------------------------
// The bag's layout: every top-level record walked and checked, the index kept.

struct Connection {
  std::uint32_t id = 0;
  std::string topic, type, md5sum;
};

struct Chunk {
  std::uint64_t pos = 0;                   // the chunk record
  std::uint64_t data_pos = 0, data_len = 0;  // its stored bytes
  std::uint64_t size = 0;                  // uncompressed
  std::string compression;
  std::int64_t start_ns = 0, end_ns = 0;   // from its chunk info
};

struct BagLayout {
  std::vector<Connection> connections;  // by id
  std::vector<Chunk> chunks;            // by start time, then place
  bool chunks_overlap = false;          // a chunk starts before the previous one ends
};

// The bag header record's index_pos, or 0 when the header cannot be read.
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
      return little_endian(field.substr(kField.size()));
    }
    pos += 4 + std::size_t{n};  // widened first: 4 + n in 32 bits wraps to 0 for n = 2^32 − 4 (a loop)
  }
  return 0;
}

// Why the bag's index cannot be used.
[[noreturn]] void no_index(const fs::path& path, std::uint64_t index, std::uint64_t size) {
  if (index == 0) {
    throw ImportError(path, "byte " + std::to_string(sizeof kMagic - 1),
                      "the bag header has no index position (the recording was not closed; `rosbag reindex` "
                      "rebuilds the index)");
  }
  throw ImportError(path, "byte " + std::to_string(index),
                    "the bag header puts the index there, but the file ends at byte " + std::to_string(size) +
                        " (truncated, or unindexed: `rosbag reindex` restores an unindexed bag)");
}

// Walks every record of the bag — uint32 header length, header (fields: uint32 length,
// "name=value"), uint32 data length, data — checking each length against what holds it, and
// keeps the index (connections, chunk infos) and the chunks' places. Every chunk info's chunk_pos
// must be where a chunk record starts, and a chunk must be able to hold the uncompressed size it
// declares (it is allocated to decompress it).
BagLayout read_layout(const fs::path& path) {
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) throw ImportError(path, 0, "cannot be read: " + ec.message());
  const std::uint64_t index = index_position(path);
  std::ifstream in(path, std::ios::binary);
  // `what` reaches past `end` (the end of the file, or of the record's header).
  auto fail = [&](std::uint64_t at, const std::string& what, std::uint64_t end, const char* region = "record header") {
    throw ImportError(path, "byte " + std::to_string(at),
                      what + ", past the end of the " + (end == size ? "file" : region) + " at byte " +
                          std::to_string(end) + " (truncated or damaged)");
  };
  auto u32_at = [&](std::uint64_t at, std::uint64_t end, const char* what, const char* region = "record header") {
    std::uint8_t b[4] = {};
    in.clear();
    in.seekg(static_cast<std::streamoff>(at));
    if (end < at + 4 || !in.read(reinterpret_cast<char*>(b), 4))
      fail(at, std::string(what) + " length cut off", end, region);
    return static_cast<std::uint32_t>(b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24);
  };
  // Calls f(name, value) for each field of the header [begin, end) — uint32 length,
  // "name=value" — after checking that the field lies inside it (values cut at kMaxStringField).
  auto for_each_field = [&](std::uint64_t begin, std::uint64_t end, const char* region, const auto& f) {
    for (std::uint64_t at = begin; at < end;) {
      const std::uint32_t field = u32_at(at, end, "header field", region);
      if (field > end - at - 4) fail(at, "a header field declares " + std::to_string(field) + " bytes", end, region);
      std::string text(std::min<std::uint64_t>(field, kMaxStringField + 64), '\0');
      in.read(text.data(), static_cast<std::streamsize>(text.size()));
      const std::size_t eq = text.find('=');
      if (eq != std::string::npos) f(std::string_view(text).substr(0, eq), std::string_view(text).substr(eq + 1));
      at += 4 + std::uint64_t{field};
    }
  };
  struct Record {
    std::uint64_t pos, data_pos, data_len, next;
    std::string op, compression, topic, type, md5sum;
    std::uint64_t conn = 0, chunk_pos = 0, size = 0;
    std::int64_t start_ns = 0, end_ns = 0;
  };
  // One record at `pos`: its header's fields and its data inside the file.
  auto record = [&](std::uint64_t pos) {
    const std::uint32_t header = u32_at(pos, size, "record header");
    if (header > size - pos - 4) fail(pos, "a record's header declares " + std::to_string(header) + " bytes", size);
    Record r{pos, 0, 0, 0, {}, {}, {}, {}, {}};
    const std::uint64_t end = pos + 4 + header;
    for_each_field(pos + 4, end, "record header", [&](std::string_view name, std::string_view value) {
      if (name == "op") r.op = value.substr(0, 1);
      else if (name == "compression") r.compression = value;
      else if (name == "chunk_pos") r.chunk_pos = little_endian(value);
      else if (name == "size") r.size = little_endian(value.substr(0, 4));
      else if (name == "conn") r.conn = little_endian(value.substr(0, 4));
      else if (name == "topic") r.topic = value;
      else if (name == "start_time") r.start_ns = time_ns(value);
      else if (name == "end_time") r.end_ns = time_ns(value);
    });
    const std::uint32_t data = u32_at(end, size, "record data");
    if (data > size - end - 4) fail(end, "a record's data declares " + std::to_string(data) + " bytes", size);
    r.data_pos = end + 4;
    r.data_len = data;
    r.next = end + 4 + data;
    // A connection record's data is the connection's own header.
    if (r.op == "\x07") {
      for_each_field(r.data_pos, r.next, "connection header", [&](std::string_view name, std::string_view value) {
        if (name == "type") r.type = value;
        else if (name == "md5sum") r.md5sum = value;
      });
    }
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
    if (r.compression != "none" && r.compression != "bz2" && r.compression != "lz4") {
      throw ImportError(path, "byte " + std::to_string(r.pos),
                        "a chunk compressed with '" + r.compression + "'; ROS 1 bags use none, bz2 or lz4");
    }
  };
  const Record first = record(sizeof kMagic - 1);  // the file header record
  if (index == 0 || index >= size) no_index(path, index, size);
  BagLayout bag;
  std::map<std::uint64_t, Chunk> chunk_records;  // by position
  std::vector<std::uint64_t> starts;
  std::vector<Record> chunk_infos;
  for (std::uint64_t pos = first.next; pos < size;) {
    const Record r = record(pos);
    starts.push_back(pos);
    if (r.op == "\x05") {
      check_chunk_size(r);
      chunk_records[pos] = Chunk{pos, r.data_pos, r.data_len, r.size, r.compression, 0, 0};
    }
    if (pos >= index && r.op == "\x06") chunk_infos.push_back(r);
    if (pos >= index && r.op == "\x07") {
      bag.connections.push_back(
          {static_cast<std::uint32_t>(r.conn), r.topic, r.type, r.md5sum});
    }
    pos = r.next;
  }
  for (const Record& c : chunk_infos) {
    const auto it = chunk_records.find(c.chunk_pos);
    if (it == chunk_records.end()) {
      const bool a_record = std::binary_search(starts.begin(), starts.end(), c.chunk_pos);
      throw ImportError(path, "index at byte " + std::to_string(index),
                        "a chunk info points at byte " + std::to_string(c.chunk_pos) +
                            (a_record ? ", where a record other than a chunk starts" : ", where no record starts") +
                            " (damaged index; `rosbag reindex` rebuilds it)");
    }
    Chunk chunk = it->second;
    chunk.start_ns = c.start_ns;
    chunk.end_ns = c.end_ns;
    bag.chunks.push_back(chunk);
  }
  std::stable_sort(bag.connections.begin(), bag.connections.end(),
                   [](const Connection& a, const Connection& b) { return a.id < b.id; });
  std::stable_sort(bag.chunks.begin(), bag.chunks.end(), [](const Chunk& a, const Chunk& b) {
    return a.start_ns != b.start_ns ? a.start_ns < b.start_ns : a.pos < b.pos;
  });
  for (std::size_t i = 1; i < bag.chunks.size(); ++i)
    bag.chunks_overlap = bag.chunks_overlap || bag.chunks[i].start_ns < bag.chunks[i - 1].end_ns;
  return bag;
}

// One chunk's records, decompressed; out holds exactly its declared size.
void read_chunk(const fs::path& path, const Chunk& c, Bytes& out) {
  const std::string where = "chunk at byte " + std::to_string(c.pos);
  Bytes stored(static_cast<std::size_t>(c.data_len));
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(c.data_pos));
  if (!in.read(reinterpret_cast<char*>(stored.data()), static_cast<std::streamsize>(stored.size())))
    throw ImportError(path, where, "cannot be read");
  if (c.compression == "none") {
    out = std::move(stored);
    return;
  }
  out.resize(static_cast<std::size_t>(c.size));
  if (c.compression == "lz4") {
    const std::string why = decompress_lz4_frame(stored.data(), stored.size(), out.data(), out.size());
    if (!why.empty()) throw ImportError(path, where, why);
    return;
  }
  unsigned int produced = static_cast<unsigned int>(out.size());
  const int rc = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out.data()), &produced,
                                            reinterpret_cast<char*>(stored.data()),
                                            static_cast<unsigned int>(stored.size()), 0, 0);
  if (rc != BZ_OK || produced != out.size()) {
    throw ImportError(path, where,
                      rc == BZ_OUTBUFF_FULL || (rc == BZ_OK && produced != out.size())
                          ? "bz2 data does not decompress to the chunk's declared " + std::to_string(c.size) + " bytes"
                          : "bz2 data is damaged (libbz2 error " + std::to_string(rc) + ")");
  }
}

// A message record inside a chunk.
struct MessageRecord {
  std::uint32_t conn = 0;
  std::int64_t time_ns = 0;
  std::size_t data = 0, len = 0;  // its bytes in the chunk
};

// The message records of a decompressed chunk (connection records skipped), each length checked
// against the chunk.
std::vector<MessageRecord> message_records(const fs::path& path, const Chunk& c, const Bytes& b) {
  std::vector<MessageRecord> out;
  auto u32 = [&](std::size_t at) {
    return static_cast<std::uint32_t>(b[at] | b[at + 1] << 8 | b[at + 2] << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24);
  };
  auto fail = [&](std::size_t at, const std::string& what) {
    throw ImportError(path, "chunk at byte " + std::to_string(c.pos) + ", byte " + std::to_string(at) + " inside it",
                      what + " (damaged chunk)");
  };
  for (std::size_t at = 0; at < b.size();) {
    if (b.size() - at < 4) fail(at, "a record's header length is cut off");
    const std::uint32_t header = u32(at);
    if (header > b.size() - at - 4) fail(at, "a record's header declares " + std::to_string(header) + " bytes, past the chunk's end");
    const std::size_t end = at + 4 + header;
    MessageRecord m;
    std::string_view op;
    for (std::size_t f = at + 4; f < end;) {
      if (end - f < 4) fail(f, "a header field's length is cut off");
      const std::uint32_t n = u32(f);
      if (n > end - f - 4) fail(f, "a header field declares " + std::to_string(n) + " bytes, past its record header");
      const std::string_view field(reinterpret_cast<const char*>(b.data()) + f + 4, n);
      const std::size_t eq = field.find('=');
      if (eq != std::string_view::npos) {
        const std::string_view name = field.substr(0, eq), value = field.substr(eq + 1);
        if (name == "op") op = value.substr(0, 1);
        else if (name == "conn") m.conn = static_cast<std::uint32_t>(little_endian(value.substr(0, 4)));
        else if (name == "time") m.time_ns = time_ns(value);
      }
      f += 4 + std::size_t{n};
    }
    if (b.size() - end < 4) fail(end, "a record's data length is cut off");
    const std::uint32_t data = u32(end);
    if (data > b.size() - end - 4) fail(end, "a record's data declares " + std::to_string(data) + " bytes, past the chunk's end");
    m.data = end + 4;
    m.len = data;
    if (op == "\x02") out.push_back(m);
    at = end + 4 + data;
  }
  return out;
}

// A chunk decompressed, with its message records.
struct ChunkData {
  Bytes bytes;
  std::vector<MessageRecord> records;
};

// The chunks read last, shared by a bag's cursors: the Imu and Temperature cursors walk the chunks
// side by side, so that each chunk is decompressed and its records listed once per pass rather
// than once per topic. A cursor keeps the chunk it reads from alive after it leaves the cache.
class ChunkCache {
 public:
  std::shared_ptr<const ChunkData> get(const fs::path& path, const Chunk& c) {
    for (const Entry& e : entries_)
      if (e.data && e.pos == c.pos) return e.data;
    Entry& e = entries_[next_];
    // The evicted chunk's buffer is reused when no cursor holds it any more.
    auto data = e.data.use_count() == 1 ? std::const_pointer_cast<ChunkData>(e.data) : std::make_shared<ChunkData>();
    e = {};  // a read that fails leaves no half-read chunk in the cache
    read_chunk(path, c, data->bytes);
    data->records = message_records(path, c, data->bytes);
    e = {c.pos, data};
    next_ = (next_ + 1) % entries_.size();
    return data;
  }

 private:
  struct Entry {
    std::uint64_t pos = 0;
    std::shared_ptr<const ChunkData> data;
  };
  std::array<Entry, 2> entries_;
  std::size_t next_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Reading one topic.

template <class Message>
class TopicCursor final : public MessageCursor<Message> {
 public:
  using Decode = Message (*)(MessageReader, std::int64_t);
  TopicCursor(const fs::path& file, const BagLayout& bag, ChunkCache& chunks, const std::string& topic, const char* md5,
              Decode decode)
      : file_(file), bag_(bag), chunks_(chunks), topic_(topic), md5_(md5), decode_(decode) {
    for (const Connection& c : bag.connections)  // in id order
      if (c.topic == topic) connections_.push_back(&c);
    if (bag.chunks_overlap) gather_in_time_order();
  }

  bool next(Message& out) override {
    while (at_ == pending_.size()) {
      if (chunk_ == bag_.chunks.size()) return false;
      pending_.clear();
      at_ = 0;
      add_messages(chunk_++);
      in_time_order();  // as rosbag record writes them, already
    }
    out = pending_[at_++];
    return true;
  }

 private:
  // The topic's connection a record is on (the first of that id), or nullptr: a binary search, the
  // connections being in id order (a crafted bag may hold many on one topic).
  const Connection* ours(const MessageRecord& m) const {
    const auto it = std::lower_bound(connections_.begin(), connections_.end(), m.conn,
                                     [](const Connection* c, std::uint32_t id) { return c->id < id; });
    return it != connections_.end() && (*it)->id == m.conn ? *it : nullptr;
  }

  Message decoded(const MessageRecord& m, std::size_t chunk) {
    const Connection& c = *ours(m);
    ++index_;
    if (c.md5sum != md5_) {
      throw ImportError(file_, "topic " + topic_,
                        c.type + " with definition MD5 " + c.md5sum + ", expected " + md5_ +
                            " (sensor_msgs as released with ROS 1)");
    }
    try {
      return decode_(MessageReader(chunk_data_->bytes.data() + m.data, m.len), m.time_ns);
    } catch (const MessageReader::Overrun&) {
      throw ImportError(file_, "message " + std::to_string(index_) + " of topic " + topic_ + " (chunk at byte " +
                                   std::to_string(bag_.chunks[chunk].pos) + ")",
                        "message of " + std::to_string(m.len) + " bytes, shorter than its type");
    }
  }

  // The topic's messages of chunk k, decoded, appended to pending_.
  void add_messages(std::size_t k) {
    chunk_data_ = chunks_.get(file_, bag_.chunks[k]);
    for (const MessageRecord& m : chunk_data_->records)
      if (ours(m)) pending_.push_back(decoded(m, k));
  }

  void in_time_order() {
    const auto by_time = [](const Message& a, const Message& b) { return a.record_ns < b.record_ns; };
    if (!std::is_sorted(pending_.begin(), pending_.end(), by_time)) std::stable_sort(pending_.begin(), pending_.end(), by_time);
  }

  // Chunks overlapping in time: every message of the topic decoded first, each chunk decompressed
  // once, then put in time order. (Taken in time order from the chunks directly, a bag of k chunks
  // interleaved message by message decompressed a chunk per message once k > 2: quadratic in the
  // bag's size, 9 s for 12 000 messages in three chunks.)
  void gather_in_time_order() {
    for (std::size_t k = 0; k < bag_.chunks.size(); ++k) add_messages(k);
    in_time_order();
    chunk_ = bag_.chunks.size();
  }

  fs::path file_;
  const BagLayout& bag_;
  ChunkCache& chunks_;
  std::string topic_;
  const char* md5_;
  Decode decode_;
  std::vector<const Connection*> connections_;
  std::shared_ptr<const ChunkData> chunk_data_;  // the chunk read last
  std::size_t chunk_ = 0;        // the next chunk (in time order)
  // The messages of the topic in chunk_ − 1, in time order; the whole topic's when chunks overlap.
  std::vector<Message> pending_;
  std::size_t at_ = 0;
  std::size_t index_ = 0;        // messages decoded
};

class Ros1Reader final : public BagReader {
 public:
  Ros1Reader(const fs::path& file, const BagLayout& bag, const std::string& topic, std::string temperature_topic)
      : file_(file), bag_(bag), temperature_topic_(std::move(temperature_topic)) {
    format = "ROS 1 bag v2.0";
    imu_topic = topic;
    if (bag.chunks_overlap) notes.push_back("the bag's chunks overlap in time, so its messages were held and put in "
                                           "time order");
  }
  std::unique_ptr<MessageCursor<ImuMessage>> imu() const override {
    return std::make_unique<TopicCursor<ImuMessage>>(file_, bag_, chunks_, imu_topic, kImuMd5, decode_imu);
  }
  std::unique_ptr<MessageCursor<TemperatureMessage>> temperature() const override {
    if (temperature_topic_.empty()) return nullptr;
    return std::make_unique<TopicCursor<TemperatureMessage>>(file_, bag_, chunks_, temperature_topic_,
                                                             kTemperatureMd5, decode_temperature);
  }

 private:
  fs::path file_;
  const BagLayout& bag_;
  std::string temperature_topic_;
  mutable ChunkCache chunks_;  // shared by the cursors it hands out (one thread)
};

std::vector<TopicInfo> bag_topics(const BagLayout& bag) {
  TopicList topics;
  for (const Connection& c : bag.connections) topics.add(c.topic, c.type);
  return topics.all();
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
  require_valid(options, "ROS bag options");
  if (!looks_like_rosbag1(path)) {
    throw ImportError(path, "byte 0", "not a ROS 1 bag: expected the magic line '#ROSBAG V2.0'");
  }
  const BagLayout bag = read_layout(path);
  const std::vector<TopicInfo> topics = bag_topics(bag);
  const std::string topic = choose_imu_topic(path, topics, options, kRos1Types);
  check_temperature_topic(path, topics, options, kRos1Types);
  stream_recording(path, Ros1Reader(path, bag, topic, options.temperature_topic), options, rec, out);
}

Recording import_rosbag1(const fs::path& path, const RosbagOptions& options) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { import_rosbag1(path, options, rec, out); });
}

}  // namespace stend::io
