// rosbag2 → Recording: the storage readers (SQLite3 .db3 and MCAP, both written here: Debian has
// no rosbag2 package) and the CDR decoding of sensor_msgs/msg/Imu and Temperature.
//
// MCAP (mcap.dev/spec): magic "\x89MCAP0\r\n", then records <opcode u8><length u64><content>, all
// little endian, up to the Footer and the closing magic. Read sequentially (a file without summary
// section works): Schema (0x03), Channel (0x04) and Message (0x05) records, also inside Chunk
// records (0x06; compression "", "lz4" frame or "zstd"); index and summary records are skipped.
// SQLite3 storage: tables topics(id, name, type, serialization_format, offered_qos_profiles) and
// messages(id, topic_id, timestamp, data); metadata.yaml (rosbag2_bagfile_information) lists the
// storage files of a bag folder in order.
#include <stend/io/rosbag.hpp>

#include "rosbag_common.hpp"

#include <lz4frame.h>
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace rosbag_detail;

namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
constexpr char kSqliteMagic[16] = "SQLite format 3";  // with its terminating NUL: 16 bytes

std::string byte_at(std::uint64_t offset) { return "byte " + std::to_string(offset); }

// "Message record (opcode 0x05)".
std::string mcap_record_name(std::uint8_t op) {
  static const char* const names[] = {"?",           "Header",          "Footer",     "Schema",        "Channel",
                                      "Message",     "Chunk",           "MessageIndex", "ChunkIndex",  "Attachment",
                                      "AttachmentIndex", "Statistics",  "Metadata",   "MetadataIndex", "SummaryOffset",
                                      "DataEnd"};
  char code[8];
  std::snprintf(code, sizeof code, "0x%02x", op);
  return std::string(op < std::size(names) ? names[op] : "unknown") + " record (opcode " + code + ")";
}

Bytes read_prefix(const fs::path& file, std::size_t n) {
  std::ifstream in(file, std::ios::binary);
  Bytes b(n);
  in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(n));
  b.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return b;
}

Bytes read_all(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ImportError(file, "byte 0", "cannot open (check the path)");
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// ---------------------------------------------------------------------------------------------
// CDR (XCDR1): a 4-byte encapsulation header (0x00 0x00 big endian, 0x00 0x01 little endian,
// then 2 option bytes); each primitive aligned to its size, counted from after the header;
// strings are a uint32 length (with the NUL) and the bytes.

class CdrReader {
 public:
  CdrReader(const Bytes& data, std::string where) : data_(data), where_(std::move(where)) {
    if (data_.size() < 4 || data_[0] != 0x00 || data_[1] > 0x01) {
      fail(data_.size() < 4 ? "shorter than the 4-byte CDR encapsulation header"
                            : "encapsulation " + std::to_string(data_[0]) + "," + std::to_string(data_[1]) +
                                  ", expected plain CDR (0,0 big endian or 0,1 little endian)");
    }
    little_ = data_[1] == 0x01;
  }
  std::uint32_t u32() { return static_cast<std::uint32_t>(unsigned_of(4)); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  double f64() {
    const std::uint64_t bits = unsigned_of(8);
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  std::string string() {
    const std::uint32_t n = u32();
    need(n);
    std::string s(reinterpret_cast<const char*>(data_.data() + pos_), n);
    pos_ += n;
    if (!s.empty() && s.back() == '\0') s.pop_back();
    return s;
  }
  Eigen::Vector3d vector3() {
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) v[k] = f64();
    return v;
  }
  void skip_f64(int n) {
    for (int i = 0; i < n; ++i) f64();
  }
  [[noreturn]] void fail(const std::string& what) const { throw Failure{where_, what}; }

  struct Failure {
    std::string where, what;
  };

 private:
  void need(std::size_t n) const {
    if (pos_ + n > data_.size()) {
      fail("ends at byte " + std::to_string(data_.size()) + " of the payload, expected " + std::to_string(n) +
           " more bytes at byte " + std::to_string(pos_) + " (" + std::to_string(data_.size()) +
           "-byte message too short for its type)");
    }
  }
  std::uint64_t unsigned_of(std::size_t size) {
    const std::size_t body = pos_ - 4;
    pos_ += (size - body % size) % size;
    need(size);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < size; ++i) {
      const std::uint64_t b = data_[pos_ + (little_ ? i : size - 1 - i)];
      v |= b << (8 * i);
    }
    pos_ += size;
    return v;
  }

  const Bytes& data_;
  std::string where_;
  bool little_ = true;
  std::size_t pos_ = 4;
};

// builtin_interfaces/Time stamp (int32 sec, uint32 nanosec), string frame_id.
std::int64_t read_header(CdrReader& in, std::string& frame_id) {
  const std::int64_t sec = in.i32();
  const std::int64_t nsec = in.u32();
  frame_id = in.string();
  return sec * 1000000000 + nsec;
}

// sensor_msgs/msg/Imu: header, orientation (4 float64), covariance (9), angular_velocity (3),
// covariance (9), linear_acceleration (3), covariance (9).
ImuMessage decode_imu(const Bytes& data, std::int64_t record_ns, const std::string& where) {
  CdrReader in(data, where);
  ImuMessage m;
  m.record_ns = record_ns;
  m.stamp_ns = read_header(in, m.frame_id);
  in.skip_f64(4 + 9);
  m.gyro_radps = in.vector3();
  in.skip_f64(9);
  m.accel_mps2 = in.vector3();
  in.skip_f64(9);
  return m;
}

// sensor_msgs/msg/Temperature: header, temperature [°C], variance.
TemperatureMessage decode_temperature(const Bytes& data, std::int64_t record_ns, const std::string& where) {
  CdrReader in(data, where);
  TemperatureMessage m;
  m.record_ns = record_ns;
  std::string frame_id;
  m.stamp_ns = read_header(in, frame_id);
  m.celsius = in.f64();
  return m;
}

// ---------------------------------------------------------------------------------------------
// The raw messages of the topics the import needs, from any storage.

struct RawMessage {
  std::int64_t record_ns = 0;
  Bytes data;
  std::string where;  // "byte 1234" / "messages row 17" in its storage file
  fs::path file;
};

struct RawBag {
  std::vector<TopicInfo> topics;
  std::map<std::string, std::vector<RawMessage>> messages;  // by topic, in storage order
  std::vector<std::string> notes;
};

void add_topic(RawBag& bag, const std::string& name, const std::string& type) {
  for (const TopicInfo& t : bag.topics) {
    if (t.name == name) return;
  }
  bag.topics.push_back({name, type});
}

// Only Imu and Temperature messages are kept; the topic is chosen once every file is read.
bool kept_type(const std::string& type) { return type == kRos2Types.imu || type == kRos2Types.temperature; }

// ---------------------------------------------------------------------------------------------
// MCAP

class McapParser {
 public:
  McapParser(const fs::path& file, RawBag& bag) : file_(file), bag_(bag) {}

  void parse_file() {
    const Bytes data = read_all(file_);
    if (data.size() < 8 || std::memcmp(data.data(), kMcapMagic, 8) != 0) {
      throw ImportError(file_, "byte 0", "not an MCAP file: expected the magic \\x89MCAP0\\r\\n");
    }
    const std::uint64_t end = parse_records(data, 8, data.size(), 0, true);
    if (end + 8 > data.size() || std::memcmp(data.data() + end, kMcapMagic, 8) != 0) {
      throw ImportError(file_, byte_at(end), "expected the closing MCAP magic after the Footer (truncated file?)");
    }
  }

 private:
  struct Channel {
    std::string topic, type, encoding;
  };

  // Records in data[pos, end); `base` = file offset of data[0] for messages (0 for the file,
  // the chunk's offset inside a chunk). Returns the offset after the Footer (top level).
  std::uint64_t parse_records(const Bytes& data, std::uint64_t pos, std::uint64_t end, std::uint64_t base,
                              bool top_level) {
    while (pos < end) {
      const std::string where = where_of(pos, base, top_level);
      if (end - pos < 9) throw ImportError(file_, where, "truncated record header (expected opcode and 8-byte length)");
      const std::uint8_t op = data[pos];
      const std::uint64_t len = le(data, pos + 1, 8);
      if (len > end - pos - 9) {
        throw ImportError(file_, where,
                          mcap_record_name(op) + " declares " + std::to_string(len) +
                              " bytes, only " + std::to_string(end - pos - 9) + " follow (truncated file?)");
      }
      const std::uint64_t body = pos + 9;
      pos = body + len;
      if (op == 0x02 && top_level) return pos;  // Footer
      Field f{data, body, body + len, file_, where};
      switch (op) {
        case 0x03: schema(f); break;
        case 0x04: channel(f); break;
        case 0x05: message(f); break;
        case 0x06:
          if (top_level) chunk(f, body);
          break;
        default: break;  // header, indexes, attachments, metadata, statistics, summary
      }
    }
    if (top_level) throw ImportError(file_, byte_at(pos), "file ends without the MCAP Footer record (truncated file?)");
    return pos;
  }

  std::string where_of(std::uint64_t pos, std::uint64_t base, bool top_level) const {
    return top_level ? byte_at(pos) : "chunk at " + byte_at(base) + ", byte " + std::to_string(pos) + " of its records";
  }

  static std::uint64_t le(const Bytes& d, std::uint64_t pos, int n) {
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(d[pos + static_cast<std::uint64_t>(i)]) << (8 * i);
    return v;
  }

  // Sequential fields of one record's content.
  struct Field {
    const Bytes& d;
    std::uint64_t pos, end;
    const fs::path& file;
    const std::string& where;
    std::uint64_t uint(int n) {
      if (end - pos < static_cast<std::uint64_t>(n)) throw ImportError(file, where, "record content shorter than its fields");
      const std::uint64_t v = le(d, pos, n);
      pos += static_cast<std::uint64_t>(n);
      return v;
    }
    Bytes bytes(std::uint64_t n) {
      if (end - pos < n) throw ImportError(file, where, "record content shorter than its fields");
      Bytes b(d.begin() + static_cast<std::ptrdiff_t>(pos), d.begin() + static_cast<std::ptrdiff_t>(pos + n));
      pos += n;
      return b;
    }
    std::string string() {
      const Bytes b = bytes(uint(4));
      return std::string(b.begin(), b.end());
    }
  };

  void schema(Field& f) {
    const auto id = static_cast<std::uint16_t>(f.uint(2));
    schemas_[id] = f.string();  // name; encoding and data are not needed
  }

  void channel(Field& f) {
    const auto id = static_cast<std::uint16_t>(f.uint(2));
    const auto schema_id = static_cast<std::uint16_t>(f.uint(2));
    Channel c;
    c.topic = f.string();
    c.encoding = f.string();
    const auto s = schemas_.find(schema_id);
    c.type = s == schemas_.end() ? std::string("(no schema)") : s->second;
    add_topic(bag_, c.topic, c.type);
    channels_[id] = c;
  }

  void message(Field& f) {
    const auto id = static_cast<std::uint16_t>(f.uint(2));
    f.uint(4);  // sequence
    const std::uint64_t log_time = f.uint(8);
    f.uint(8);  // publish_time
    const auto c = channels_.find(id);
    if (c == channels_.end()) throw ImportError(file_, f.where, "message on channel " + std::to_string(id) + " before its Channel record");
    if (!kept_type(c->second.type)) return;
    if (c->second.encoding != "cdr") {
      throw ImportError(file_, f.where, "topic " + c->second.topic + " has message encoding '" + c->second.encoding + "', expected cdr");
    }
    bag_.messages[c->second.topic].push_back({static_cast<std::int64_t>(log_time), f.bytes(f.end - f.pos), f.where, file_});
  }

  void chunk(Field& f, std::uint64_t offset) {
    f.uint(8);  // message_start_time
    f.uint(8);  // message_end_time
    const std::uint64_t size = f.uint(8);
    const auto crc = static_cast<std::uint32_t>(f.uint(4));
    const std::string compression = f.string();
    const Bytes stored = f.bytes(f.uint(8));
    const Bytes records = decompress(stored, compression, size, f.where);
    if (crc != 0 && static_cast<std::uint32_t>(crc32(0, records.data(), static_cast<uInt>(records.size()))) != crc) {
      throw ImportError(file_, f.where, "chunk CRC mismatch (corrupt data)");
    }
    ++chunks_[compression.empty() ? "none" : compression];
    parse_records(records, 0, records.size(), offset, false);
  }

  Bytes decompress(const Bytes& in, const std::string& compression, std::uint64_t size, const std::string& where) {
    if (compression.empty()) {
      if (in.size() != size) throw ImportError(file_, where, "uncompressed chunk size differs from its declared size");
      return in;
    }
    Bytes out(size);
    if (compression == "zstd") {
      const std::size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
      if (ZSTD_isError(n) || n != size) {
        throw ImportError(file_, where, std::string("zstd chunk does not decompress to its declared size: ") +
                                            (ZSTD_isError(n) ? ZSTD_getErrorName(n) : "size differs"));
      }
      return out;
    }
    if (compression == "lz4") return lz4_frame(in, size, where);
    throw ImportError(file_, where, "chunk compression '" + compression + "', expected none, lz4 or zstd");
  }

  Bytes lz4_frame(const Bytes& in, std::uint64_t size, const std::string& where) {
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) throw ImportError(file_, where, "lz4: no context");
    const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> guard(ctx, LZ4F_freeDecompressionContext);
    Bytes out(size);
    std::size_t in_pos = 0, out_pos = 0;
    std::size_t hint = 1;
    while (hint != 0 && in_pos < in.size()) {
      std::size_t out_n = out.size() - out_pos, in_n = in.size() - in_pos;
      hint = LZ4F_decompress(ctx, out.data() + out_pos, &out_n, in.data() + in_pos, &in_n, nullptr);
      if (LZ4F_isError(hint)) throw ImportError(file_, where, std::string("lz4 chunk: ") + LZ4F_getErrorName(hint));
      in_pos += in_n;
      out_pos += out_n;
      if (in_n == 0 && out_n == 0) break;
    }
    if (hint != 0 || out_pos != size) throw ImportError(file_, where, "lz4 chunk does not decompress to its declared size");
    return out;
  }

 public:
  std::string chunk_note() const {
    if (chunks_.empty()) return "MCAP " + file_.filename().string() + ": messages outside chunks";
    std::string s = "MCAP " + file_.filename().string() + ": chunks";
    for (const auto& [compression, n] : chunks_) s += " " + std::to_string(n) + " " + compression;
    return s;
  }

 private:
  fs::path file_;
  RawBag& bag_;
  std::map<std::uint16_t, std::string> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::map<std::string, int> chunks_;
};

void read_mcap(const fs::path& file, RawBag& bag) {
  McapParser p(file, bag);
  p.parse_file();
  bag.notes.push_back(p.chunk_note());
}

// ---------------------------------------------------------------------------------------------
// SQLite3

struct Db {
  sqlite3* db = nullptr;
  ~Db() { sqlite3_close(db); }
};
struct Stmt {
  sqlite3_stmt* s = nullptr;
  ~Stmt() { sqlite3_finalize(s); }
};

void prepare(const fs::path& file, Db& db, Stmt& st, const char* sql) {
  if (sqlite3_prepare_v2(db.db, sql, -1, &st.s, nullptr) != SQLITE_OK) {
    throw ImportError(file, "SQLite", std::string("cannot read the rosbag2 tables topics and messages: ") +
                                          sqlite3_errmsg(db.db) + " (truncated or not a rosbag2 database?)");
  }
}

std::string column_text(sqlite3_stmt* s, int i) {
  const unsigned char* t = sqlite3_column_text(s, i);
  return t ? reinterpret_cast<const char*>(t) : "";
}

void read_db3(const fs::path& file, RawBag& bag) {
  Db db;
  if (sqlite3_open_v2(file.c_str(), &db.db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    throw ImportError(file, "SQLite", std::string("cannot open: ") + sqlite3_errmsg(db.db));
  }
  std::map<std::int64_t, std::string> topic_of;
  {
    Stmt st;
    prepare(file, db, st, "SELECT id, name, type, serialization_format FROM topics ORDER BY id");
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const std::string name = column_text(st.s, 1), type = column_text(st.s, 2), format = column_text(st.s, 3);
      add_topic(bag, name, type);
      if (kept_type(type) && format != "cdr") {
        throw ImportError(file, "topics row " + std::to_string(sqlite3_column_int64(st.s, 0)),
                          "topic " + name + " serialized as '" + format + "', expected cdr");
      }
      if (kept_type(type)) topic_of[sqlite3_column_int64(st.s, 0)] = name;
    }
    if (rc != SQLITE_DONE) throw ImportError(file, "topics table", std::string("read error: ") + sqlite3_errmsg(db.db));
  }
  Stmt st;
  prepare(file, db, st, "SELECT id, topic_id, timestamp, data FROM messages ORDER BY timestamp, id");
  int rc;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    const auto t = topic_of.find(sqlite3_column_int64(st.s, 1));
    if (t == topic_of.end()) continue;
    const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(st.s, 3));
    const int n = sqlite3_column_bytes(st.s, 3);
    bag.messages[t->second].push_back({sqlite3_column_int64(st.s, 2), Bytes(blob, blob + n),
                                       "messages row id " + std::to_string(sqlite3_column_int64(st.s, 0)), file});
  }
  if (rc != SQLITE_DONE) throw ImportError(file, "messages table", std::string("read error: ") + sqlite3_errmsg(db.db));
  bag.notes.push_back("SQLite3 storage " + file.filename().string());
}

bool is_sqlite(const fs::path& file) {
  const Bytes head = read_prefix(file, sizeof kSqliteMagic);
  return head.size() == sizeof kSqliteMagic && std::memcmp(head.data(), kSqliteMagic, sizeof kSqliteMagic) == 0;
}

bool is_rosbag2_db3(const fs::path& file) {
  if (!is_sqlite(file)) return false;
  Db db;
  if (sqlite3_open_v2(file.c_str(), &db.db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) return false;
  Stmt st;
  if (sqlite3_prepare_v2(db.db,
                         "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN ('topics', 'messages')",
                         -1, &st.s, nullptr) != SQLITE_OK) {
    return false;
  }
  return sqlite3_step(st.s) == SQLITE_ROW && sqlite3_column_int(st.s, 0) == 2;
}

bool is_mcap(const fs::path& file) {
  const Bytes head = read_prefix(file, 8);
  return head.size() == 8 && std::memcmp(head.data(), kMcapMagic, 8) == 0;
}

// ---------------------------------------------------------------------------------------------
// A bag folder: the files metadata.yaml lists, else every storage file in name order.

std::vector<fs::path> storage_files(const fs::path& dir) {
  std::vector<fs::path> files;
  const fs::path meta = dir / "metadata.yaml";
  if (fs::exists(meta)) {
    try {
      const YAML::Node info = YAML::LoadFile(meta.string())["rosbag2_bagfile_information"];
      if (!info) throw ImportError(meta, 1, "expected the key rosbag2_bagfile_information");
      if (const YAML::Node c = info["compression_format"]; c && !c.as<std::string>().empty()) {
        throw ImportError(meta, 1, "compression_format '" + c.as<std::string>() +
                                       "' is not supported: decompress the bag first (ros2 bag convert)");
      }
      for (const YAML::Node& f : info["relative_file_paths"]) files.push_back(dir / f.as<std::string>());
    } catch (const YAML::Exception& e) {
      throw ImportError(meta, static_cast<std::size_t>(e.mark.line + 1), e.what());
    }
    for (const fs::path& f : files) {
      if (!fs::is_regular_file(f)) throw ImportError(meta, 0, "lists " + f.filename().string() + ", which is not in the folder");
    }
    return files;
  }
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_regular_file() && (is_mcap(e.path()) || is_rosbag2_db3(e.path()))) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

RawBag read_storage(const fs::path& path) {
  RawBag bag;
  const std::vector<fs::path> files = fs::is_directory(path) ? storage_files(path) : std::vector<fs::path>{path};
  if (files.empty()) throw ImportError(path, "folder", "no rosbag2 storage file (expected metadata.yaml, .db3 or MCAP)");
  for (const fs::path& f : files) {
    if (is_mcap(f)) {
      read_mcap(f, bag);
    } else if (is_sqlite(f)) {
      read_db3(f, bag);  // says why when it is not a readable rosbag2 database
    } else {
      throw ImportError(f, "byte 0", "neither MCAP (magic \\x89MCAP0\\r\\n) nor a rosbag2 SQLite3 database");
    }
  }
  return bag;
}

template <class Message, class Decode>
std::vector<Message> decode_all(const std::vector<RawMessage>& raw, const std::string& topic, Decode decode) {
  std::vector<Message> out;
  out.reserve(raw.size());
  for (const RawMessage& m : raw) {
    try {
      out.push_back(decode(m.data, m.record_ns, m.where));
    } catch (const CdrReader::Failure& e) {
      throw ImportError(m.file, e.where, "topic " + topic + ": " + e.what);
    }
  }
  return out;
}

}  // namespace

bool looks_like_rosbag2(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return is_mcap(path) || is_rosbag2_db3(path);
  if (!fs::is_directory(path, ec)) return false;
  for (const auto& e : fs::directory_iterator(path, ec)) {
    if (e.is_regular_file() && (is_mcap(e.path()) || is_rosbag2_db3(e.path()))) return true;
  }
  return false;
}

Recording import_rosbag2(const fs::path& path, const RosbagOptions& options) {
  if (!fs::exists(path)) throw ImportError(path, "path", "no such file or folder");
  RawBag raw = read_storage(path);
  BagContent c;
  c.format = "rosbag2";
  c.imu_topic = choose_imu_topic(path, raw.topics, options, kRos2Types);
  check_temperature_topic(path, raw.topics, options, kRos2Types);
  c.imu = decode_all<ImuMessage>(raw.messages[c.imu_topic], c.imu_topic, decode_imu);
  if (!options.temperature_topic.empty()) {
    c.temperature = decode_all<TemperatureMessage>(raw.messages[options.temperature_topic], options.temperature_topic,
                                                   decode_temperature);
  }
  c.notes = std::move(raw.notes);
  c.notes.push_back("CDR payloads");
  return make_recording(path, c, options);
}

}  // namespace stend::io
