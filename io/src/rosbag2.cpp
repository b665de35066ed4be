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

#include "import_common.hpp"
#include "rosbag_common.hpp"

#include <sqlite3.h>
#include <yaml-cpp/yaml.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <cstdint>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace rosbag_detail;

namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
constexpr char kSqliteMagic[16] = "SQLite format 3";  // with its terminating NUL: 16 bytes

std::string byte_at(std::uint64_t offset) { return "byte " + std::to_string(offset); }

// Where a record lies in its storage file, put into words only for a message ("byte 1234",
// "chunk at byte 99, byte 12 of its records", "messages row id 17"): words made per record cost
// more than decoding it.
struct Place {
  enum class Kind { kByte, kChunkRecord, kRow };
  Kind kind = Kind::kByte;
  std::uint64_t at = 0;      // kByte: the file's byte; kChunkRecord: the chunk's
  std::uint64_t record = 0;  // kChunkRecord: the byte in the chunk's records
  std::int64_t row = 0;      // kRow: the messages table's row id
  std::string text() const {
    switch (kind) {
      case Kind::kChunkRecord: return "chunk at " + byte_at(at) + ", byte " + std::to_string(record) + " of its records";
      case Kind::kRow: return "messages row id " + std::to_string(row);
      case Kind::kByte: break;
    }
    return byte_at(at);
  }
};

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

// ---------------------------------------------------------------------------------------------
// CDR (XCDR1): a 4-byte encapsulation header (0x00 0x00 big endian, 0x00 0x01 little endian,
// then 2 option bytes); each primitive aligned to its size, counted from after the header;
// strings are a uint32 length (with the NUL) and the bytes.

class CdrReader {
 public:
  CdrReader(const std::uint8_t* data, std::size_t size, const Place& where)
      : data_(data), size_(size), where_(where) {
    if (size_ < 4 || data_[0] != 0x00 || data_[1] > 0x01) {
      fail(size_ < 4 ? "shorter than the 4-byte CDR encapsulation header"
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
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    if (!s.empty() && s.back() == '\0') s.pop_back();
    return s;
  }
  Eigen::Vector3d vector3() {
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) v[k] = f64();
    return v;
  }
  // n float64s passed over unread (they are contiguous once the first is aligned).
  void skip_f64(int n) {
    if (n <= 0) return;
    align(8);
    need(8 * static_cast<std::size_t>(n));
    pos_ += 8 * static_cast<std::size_t>(n);
  }
  [[noreturn]] void fail(const std::string& what) const { throw Failure{where_.text(), what}; }

  struct Failure {
    std::string where, what;
  };

 private:
  void need(std::size_t n) const {
    if (pos_ + n > size_) {
      fail("ends at byte " + std::to_string(size_) + " of the payload, expected " + std::to_string(n) +
           " more bytes at byte " + std::to_string(pos_) + " (" + std::to_string(size_) +
           "-byte message too short for its type)");
    }
  }
  // Moves to the next multiple of `size` bytes from the end of the encapsulation header.
  void align(std::size_t size) {
    const std::size_t body = pos_ - 4;
    pos_ += (size - body % size) % size;
  }
  std::uint64_t unsigned_of(std::size_t size) {
    align(size);
    need(size);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < size; ++i) {
      const std::uint64_t b = data_[pos_ + (little_ ? i : size - 1 - i)];
      v |= b << (8 * i);
    }
    pos_ += size;
    return v;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  const Place& where_;
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
ImuMessage decode_imu(const std::uint8_t* data, std::size_t size, std::int64_t record_ns, const Place& where) {
  CdrReader in(data, size, where);
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
TemperatureMessage decode_temperature(const std::uint8_t* data, std::size_t size, std::int64_t record_ns,
                                      const Place& where) {
  CdrReader in(data, size, where);
  TemperatureMessage m;
  m.record_ns = record_ns;
  std::string frame_id;
  m.stamp_ns = read_header(in, frame_id);
  m.celsius = in.f64();
  return m;
}

// ---------------------------------------------------------------------------------------------
// The raw messages of the Imu and Temperature topics, from any storage, one at a time.

// A message as its storage holds it; data stays valid until the cursor's next step.
struct RawMessage {
  const std::string* topic = nullptr;
  std::int64_t record_ns = 0;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  Place where;  // in its storage file
};

// Only Imu and Temperature messages are kept; the topic is chosen once every file is read.
bool kept_type(const std::string& type) { return type == kRos2Types.imu || type == kRos2Types.temperature; }

// One storage file's kept messages in storage order.
class StorageFile {
 public:
  // Every topic the file declares is added to `topics` when given (the first pass: the later ones
  // need only their kept topics, and a crafted bag may declare hundreds of thousands).
  explicit StorageFile(TopicList* topics) : topics_(topics) {}
  virtual ~StorageFile() = default;
  virtual bool next(RawMessage& m) = 0;
  // What was read, for the info event.
  virtual std::string note() const = 0;

 protected:
  void saw_topic(const std::string& name, const std::string& type) {
    if (topics_) topics_->add(name, type);
  }

 private:
  TopicList* topics_;
};

// ---------------------------------------------------------------------------------------------
// MCAP, through a bounded buffer: a top-level record at a time, a chunk decompressed whole.

class McapFile final : public StorageFile {
 public:
  McapFile(const fs::path& file, TopicList* topics) : StorageFile(topics), in_(file) {
    if (in_.size() < 8 || std::memcmp(read(0, 8, "the magic"), kMcapMagic, 8) != 0) {
      throw ImportError(file, "byte 0", "not an MCAP file: expected the magic \\x89MCAP0\\r\\n");
    }
  }

  bool next(RawMessage& m) override {
    for (;;) {
      if (chunk_pos_ < records_.size()) {
        if (chunk_record(m)) return true;
      } else if (done_) {
        return false;
      } else if (top_record(m)) {
        return true;
      }
    }
  }

  std::string note() const override {
    const std::string name = in_.file().filename().string();
    if (chunks_.empty()) return "MCAP " + name + ": messages outside chunks";
    std::string s = "MCAP " + name + ": chunks";
    for (const auto& [compression, n] : chunks_) s += " " + std::to_string(n) + " " + compression;
    return s;
  }

 private:
  struct Channel {
    std::string topic, type, encoding;
  };

  const std::uint8_t* read(std::uint64_t pos, std::uint64_t n, std::string_view what) {
    in_.need(pos, n, what);
    return in_.at(pos);
  }

  // The top-level record at pos_: a message (true, in m), or anything else handled (false).
  bool top_record(RawMessage& m) {
    const fs::path& file = in_.file();
    const std::uint64_t pos = pos_;
    const Place where{Place::Kind::kByte, pos};
    if (in_.size() - pos < 9) {
      throw ImportError(file, byte_at(pos),
                        pos == in_.size() ? "file ends without the MCAP Footer record (truncated file?)"
                                          : "truncated record header (expected opcode and 8-byte length)");
    }
    const std::uint8_t* head = read(pos, 9, "a record header");
    const std::uint8_t op = head[0];
    const std::uint64_t len = le(head + 1, 8);
    if (len > in_.size() - pos - 9) {
      throw ImportError(file, where.text(),
                        mcap_record_name(op) + " declares " + std::to_string(len) + " bytes, only " +
                            std::to_string(in_.size() - pos - 9) + " follow (truncated file?)");
    }
    pos_ = pos + 9 + len;
    if (op == 0x02) {  // Footer, then the closing magic
      done_ = true;
      if (pos_ + 8 > in_.size() || std::memcmp(read(pos_, 8, "the closing magic"), kMcapMagic, 8) != 0) {
        throw ImportError(file, byte_at(pos_), "expected the closing MCAP magic after the Footer (truncated file?)");
      }
      return false;
    }
    if (op != 0x03 && op != 0x04 && op != 0x05 && op != 0x06) return false;  // indexes, attachments, ...
    Field f{read(pos + 9, len, mcap_record_name(op)), 0, len, file, where};
    if (op == 0x06) {
      chunk(f, pos);
      return false;
    }
    return record(op, f, m);
  }

  // The record at chunk_pos_ inside the current chunk.
  bool chunk_record(RawMessage& m) {
    const fs::path& file = in_.file();
    const std::uint64_t pos = chunk_pos_, end = records_.size();
    const Place where{Place::Kind::kChunkRecord, chunk_at_, pos};
    if (end - pos < 9) throw ImportError(file, where.text(), "truncated record header (expected opcode and 8-byte length)");
    const std::uint8_t op = records_[pos];
    const std::uint64_t len = le(records_.data() + pos + 1, 8);
    if (len > end - pos - 9) {
      throw ImportError(file, where.text(),
                        mcap_record_name(op) + " declares " + std::to_string(len) + " bytes, only " +
                            std::to_string(end - pos - 9) + " follow (truncated file?)");
    }
    chunk_pos_ = pos + 9 + len;
    if (op != 0x03 && op != 0x04 && op != 0x05) return false;
    Field f{records_.data() + pos + 9, 0, len, file, where};
    return record(op, f, m);
  }

  static std::uint64_t le(const std::uint8_t* d, int n) {
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(d[i]) << (8 * i);
    return v;
  }

  // Sequential fields of one record's content d[0, end).
  struct Field {
    const std::uint8_t* d;
    std::uint64_t pos, end;
    const fs::path& file;
    const Place& where;
    void need(std::uint64_t n) const {
      if (end - pos < n) throw ImportError(file, where.text(), "record content shorter than its fields");
    }
    std::uint64_t uint(int n) {
      need(static_cast<std::uint64_t>(n));
      const std::uint64_t v = le(d + pos, n);
      pos += static_cast<std::uint64_t>(n);
      return v;
    }
    const std::uint8_t* bytes(std::uint64_t n) {
      need(n);
      const std::uint8_t* p = d + pos;
      pos += n;
      return p;
    }
    std::string string() {
      const std::uint64_t n = uint(4);
      const auto* p = reinterpret_cast<const char*>(bytes(n));
      return std::string(p, n);
    }
  };

  // A Schema, Channel or Message record; true for a kept message (in m).
  bool record(std::uint8_t op, Field& f, RawMessage& m) {
    if (op == 0x03) {
      const auto id = static_cast<std::uint16_t>(f.uint(2));
      schemas_[id] = f.string();  // name; encoding and data are not needed
      return false;
    }
    if (op == 0x04) {
      channel(f);
      return false;
    }
    const auto id = static_cast<std::uint16_t>(f.uint(2));
    f.uint(4);  // sequence
    const std::uint64_t log_time = f.uint(8);
    f.uint(8);  // publish_time
    const auto c = channels_.find(id);
    if (c == channels_.end()) {
      throw ImportError(in_.file(), f.where.text(), "message on channel " + std::to_string(id) + " before its Channel record");
    }
    if (!kept_type(c->second.type)) return false;
    if (c->second.encoding != "cdr") {
      throw ImportError(in_.file(), f.where.text(),
                        "topic " + c->second.topic + " has message encoding '" + c->second.encoding + "', expected cdr");
    }
    m.topic = &c->second.topic;
    m.record_ns = static_cast<std::int64_t>(log_time);
    m.size = f.end - f.pos;
    m.data = f.bytes(m.size);
    m.where = f.where;
    return true;
  }

  void channel(Field& f) {
    const auto id = static_cast<std::uint16_t>(f.uint(2));
    const auto schema_id = static_cast<std::uint16_t>(f.uint(2));
    Channel c;
    c.topic = f.string();
    c.encoding = f.string();
    const auto s = schemas_.find(schema_id);
    c.type = s == schemas_.end() ? std::string("(no schema)") : s->second;
    saw_topic(c.topic, c.type);
    channels_[id] = c;
  }

  // A chunk's records into records_ (decompressed), to be read from chunk_pos_ = 0.
  void chunk(Field& f, std::uint64_t offset) {
    f.uint(8);  // message_start_time
    f.uint(8);  // message_end_time
    const std::uint64_t size = f.uint(8);
    const auto crc = static_cast<std::uint32_t>(f.uint(4));
    const std::string compression = f.string();
    const std::uint64_t stored_size = f.uint(8);
    const std::uint8_t* stored = f.bytes(stored_size);
    decompress(stored, stored_size, compression, size, f.where.text());
    if (crc != 0 && static_cast<std::uint32_t>(crc32(0, records_.data(), static_cast<uInt>(records_.size()))) != crc) {
      throw ImportError(in_.file(), f.where.text(), "chunk CRC mismatch (corrupt data)");
    }
    ++chunks_[compression.empty() ? "none" : compression];
    chunk_at_ = offset;
    chunk_pos_ = 0;
  }

  void decompress(const std::uint8_t* in, std::uint64_t in_size, const std::string& compression, std::uint64_t size,
                  const std::string& where) {
    const fs::path& file = in_.file();
    if (compression.empty()) {
      if (in_size != size) throw ImportError(file, where, "uncompressed chunk size differs from its declared size");
      records_.assign(in, in + in_size);
      return;
    }
    check_declared_size(in, in_size, compression, size, where);
    records_.resize(size);
    if (compression == "zstd") {
      const std::size_t n = ZSTD_decompress(records_.data(), records_.size(), in, in_size);
      if (ZSTD_isError(n) || n != size) {
        throw ImportError(file, where, std::string("zstd chunk does not decompress to its declared size: ") +
                                           (ZSTD_isError(n) ? ZSTD_getErrorName(n) : "size differs"));
      }
      return;
    }
    if (compression == "lz4") return lz4_frame(in, in_size, size, where);
    throw ImportError(file, where, "chunk compression '" + compression + "', expected none, lz4 or zstd");
  }

  // Refuses a declared uncompressed size the stored bytes cannot produce, before allocating it:
  // a zstd frame states its content size (when it does, the two must agree); lz4 expands at most
  // 255:1.
  // A chunk is decompressed whole, so its declared size is held to kMaxChunkBytes: a zstd frame can
  // state any size and fill it with run-length blocks of a few bytes each (50 kB of input made
  // 1 GB), and memory must stay bounded on any input. MCAP writers make chunks of 1 MiB or less
  // by default.
  static constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{256} << 20;
  void check_declared_size(const std::uint8_t* in, std::uint64_t in_size, const std::string& compression,
                           std::uint64_t size, const std::string& where) const {
    std::uint64_t most = 255 * in_size + 64;  // lz4, and a zstd frame that does not state its size
    if (compression == "zstd") {
      const unsigned long long framed = ZSTD_getFrameContentSize(in, in_size);
      if (framed != ZSTD_CONTENTSIZE_UNKNOWN && framed != ZSTD_CONTENTSIZE_ERROR) most = framed;
      else if (framed == ZSTD_CONTENTSIZE_UNKNOWN) most = std::numeric_limits<std::uint32_t>::max();
    }
    if (size > most) {
      throw ImportError(in_.file(), where, "chunk declares " + std::to_string(size) + " uncompressed bytes, more than its " +
                                               std::to_string(in_size) + " " + compression + " bytes can hold (damaged header)");
    }
    if (size > kMaxChunkBytes) {
      throw ImportError(in_.file(), where, "chunk declares " + std::to_string(size) + " uncompressed bytes, more than the " +
                                               std::to_string(kMaxChunkBytes >> 20) + " MiB Stend reads in one chunk");
    }
  }

  void lz4_frame(const std::uint8_t* in, std::uint64_t in_size, std::uint64_t size, const std::string& where) {
    const std::string why = decompress_lz4_frame(in, in_size, records_.data(), size);
    if (!why.empty()) throw ImportError(in_.file(), where, why);
  }

  detail::BinaryReader in_;
  std::uint64_t pos_ = 8;  // the next top-level record
  bool done_ = false;      // the Footer was read
  Bytes records_;          // the current chunk's records, decompressed
  std::uint64_t chunk_pos_ = 0, chunk_at_ = 0;  // the next record in it; the chunk's file offset
  std::map<std::uint16_t, std::string> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::map<std::string, int> chunks_;
};

// ---------------------------------------------------------------------------------------------
// SQLite3: stepping the messages query of the kept topics.

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

class Db3File final : public StorageFile {
 public:
  Db3File(const fs::path& file, TopicList* topics) : StorageFile(topics), file_(file) {
    if (sqlite3_open_v2(file.c_str(), &db_.db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      throw ImportError(file, "SQLite", std::string("cannot open: ") + sqlite3_errmsg(db_.db));
    }
    read_topics();
    prepare(file_, db_, messages_, "SELECT id, topic_id, timestamp, data FROM messages ORDER BY timestamp, id");
  }

  bool next(RawMessage& m) override {
    for (;;) {
      const int rc = sqlite3_step(messages_.s);
      if (rc == SQLITE_DONE) return false;
      if (rc != SQLITE_ROW) throw ImportError(file_, "messages table", std::string("read error: ") + sqlite3_errmsg(db_.db));
      const auto t = topic_of_.find(sqlite3_column_int64(messages_.s, 1));
      if (t == topic_of_.end()) continue;
      m.topic = &t->second;
      m.record_ns = sqlite3_column_int64(messages_.s, 2);
      m.data = static_cast<const std::uint8_t*>(sqlite3_column_blob(messages_.s, 3));
      m.size = static_cast<std::size_t>(sqlite3_column_bytes(messages_.s, 3));
      m.where = Place{Place::Kind::kRow, 0, 0, sqlite3_column_int64(messages_.s, 0)};
      return true;
    }
  }

  std::string note() const override { return "SQLite3 storage " + file_.filename().string(); }

 private:
  void read_topics() {
    Stmt st;
    prepare(file_, db_, st, "SELECT id, name, type, serialization_format FROM topics ORDER BY id");
    int rc;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const std::string name = column_text(st.s, 1), type = column_text(st.s, 2), format = column_text(st.s, 3);
      saw_topic(name, type);
      if (kept_type(type) && format != "cdr") {
        throw ImportError(file_, "topics row " + std::to_string(sqlite3_column_int64(st.s, 0)),
                          "topic " + name + " serialized as '" + format + "', expected cdr");
      }
      if (kept_type(type)) topic_of_[sqlite3_column_int64(st.s, 0)] = name;
    }
    if (rc != SQLITE_DONE) throw ImportError(file_, "topics table", std::string("read error: ") + sqlite3_errmsg(db_.db));
  }

  fs::path file_;
  Db db_;
  Stmt messages_;
  std::map<std::int64_t, std::string> topic_of_;
};

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

std::unique_ptr<StorageFile> open_storage(const fs::path& f, TopicList* topics) {
  if (is_mcap(f)) return std::make_unique<McapFile>(f, topics);
  if (is_sqlite(f)) return std::make_unique<Db3File>(f, topics);  // says why when it is not a readable rosbag2 database
  throw ImportError(f, "byte 0", "neither MCAP (magic \\x89MCAP0\\r\\n) nor a rosbag2 SQLite3 database");
}

// The kept messages of every storage file of the bag, in order, one at a time; each message with
// the file it is in. Every topic the files declare is added to `topics` when given.
class StorageCursor {
 public:
  explicit StorageCursor(const std::vector<fs::path>& files, TopicList* topics = nullptr)
      : files_(&files), topics_(topics) {}
  bool next(RawMessage& m) {
    for (;;) {
      if (!current_) {
        if (index_ == files_->size()) return false;
        current_ = open_storage((*files_)[index_++], topics_);
      }
      if (current_->next(m)) return true;
      notes.push_back(current_->note());
      current_.reset();
    }
  }
  const fs::path& file() const { return (*files_)[index_ - 1]; }
  std::vector<std::string> notes;  // of the files read to the end

 private:
  const std::vector<fs::path>* files_;
  TopicList* topics_;
  std::size_t index_ = 0;
  std::unique_ptr<StorageFile> current_;
};

// One pass over the storage for a pass's Imu and Temperature cursors together: each pulls the
// storage on for its own topic and leaves the other topic's messages it passes, decoded, in the
// other's queue, so that the storage is read once per pass instead of once per topic. A queue that
// grows past kMaxAhead messages (its cursor not pulling: a temperature topic out of time order is
// read whole first, or Temperature messages are further apart than that) is dropped and its side leaves the pass; its cursor goes on alone (see
// TopicCursor).
class SharedPass {
 public:
  static constexpr std::size_t kMaxAhead = 16384;  // messages held for the cursor behind (≈ 1.6 MB of Imu)

  // A topic left empty has no side in the pass.
  SharedPass(const std::vector<fs::path>& files, std::string imu_topic, std::string temperature_topic)
      : storage_(files),
        imu_{std::move(imu_topic), decode_imu, {}, false},
        temperature_{std::move(temperature_topic), decode_temperature, {}, false} {
    imu_.shared = !imu_.topic.empty();
    temperature_.shared = !temperature_.topic.empty();
  }

  // Whether the topic of Message is still read through this pass.
  template <class Message>
  bool shared() const { return side<Message>().shared; }

  // The next message of Message's topic, from its queue or the storage.
  template <class Message>
  bool next(Message& out) {
    Side<Message>& me = side<Message>();
    if (!me.ahead.empty()) {
      out = std::move(me.ahead.front());
      me.ahead.pop_front();
      return true;
    }
    for (RawMessage m; storage_.next(m);) {
      if (*m.topic == me.topic) {
        out = decoded(me, m);
        return true;
      }
      hold(imu_, m);
      hold(temperature_, m);
    }
    return false;
  }

 private:
  template <class Message>
  struct Side {
    std::string topic;
    Message (*decode)(const std::uint8_t*, std::size_t, std::int64_t, const Place&);
    std::deque<Message> ahead;  // passed by the other side's cursor, not yet taken
    bool shared = true;
  };

  template <class Message>
  Side<Message>& side() {
    if constexpr (std::is_same_v<Message, ImuMessage>) return imu_;
    else return temperature_;
  }
  template <class Message>
  const Side<Message>& side() const {
    if constexpr (std::is_same_v<Message, ImuMessage>) return imu_;
    else return temperature_;
  }

  template <class Message>
  Message decoded(const Side<Message>& s, const RawMessage& m) {
    try {
      return s.decode(m.data, m.size, m.record_ns, m.where);
    } catch (const CdrReader::Failure& e) {
      throw ImportError(storage_.file(), e.where, "topic " + s.topic + ": " + e.what);
    }
  }

  template <class Message>
  void hold(Side<Message>& s, const RawMessage& m) {
    if (!s.shared || *m.topic != s.topic) return;
    s.ahead.push_back(decoded(s, m));
    if (s.ahead.size() > kMaxAhead) {
      s.shared = false;
      std::deque<Message>().swap(s.ahead);
    }
  }

  StorageCursor storage_;
  Side<ImuMessage> imu_;
  Side<TemperatureMessage> temperature_;
};

// The messages of one topic, decoded: through the pass it shares with the other topic's cursor
// while it can, then through a pass of its own that skips the messages already taken.
template <class Message>
class TopicCursor final : public MessageCursor<Message> {
 public:
  TopicCursor(std::shared_ptr<SharedPass> pass, const std::vector<fs::path>& files, std::string topic)
      : pass_(std::move(pass)), files_(files), topic_(std::move(topic)) {}
  bool next(Message& out) override {
    if (!alone_ && pass_->shared<Message>()) {
      if (!pass_->next(out)) return false;
      ++taken_;
      return true;
    }
    if (!alone_) {
      const bool imu = std::is_same_v<Message, ImuMessage>;
      alone_ = std::make_unique<SharedPass>(files_, imu ? topic_ : "", imu ? "" : topic_);
      for (Message skipped; taken_ > 0 && alone_->next(skipped);) --taken_;
    }
    return alone_->next(out);
  }

 private:
  std::shared_ptr<SharedPass> pass_;
  const std::vector<fs::path>& files_;
  std::string topic_;
  std::uint64_t taken_ = 0;              // from the shared pass
  std::unique_ptr<SharedPass> alone_;    // once the shared pass has dropped this topic
};

// The bag's two passes (stream_recording's scan, then its conversion) each ask for an Imu and a
// Temperature cursor, in either order: the second of a pair joins the pass the first opened.
class Ros2Reader final : public BagReader {
 public:
  Ros2Reader(std::vector<fs::path> files, std::string temperature_topic)
      : files_(std::move(files)), temperature_topic_(std::move(temperature_topic)) {
    format = "rosbag2";
  }
  std::unique_ptr<MessageCursor<ImuMessage>> imu() const override {
    return std::make_unique<TopicCursor<ImuMessage>>(pass_for(open_imu_, open_temperature_), files_, imu_topic);
  }
  std::unique_ptr<MessageCursor<TemperatureMessage>> temperature() const override {
    if (temperature_topic_.empty()) return nullptr;
    return std::make_unique<TopicCursor<TemperatureMessage>>(pass_for(open_temperature_, open_imu_), files_,
                                                             temperature_topic_);
  }

 private:
  // The pass a cursor joins: the one the other topic's cursor opened, if it is still open and this
  // topic has no cursor in it yet; else a new one, open for the other topic.
  std::shared_ptr<SharedPass> pass_for(std::weak_ptr<SharedPass>& mine, std::weak_ptr<SharedPass>& other) const {
    if (auto pass = mine.lock()) {
      mine.reset();
      return pass;
    }
    auto pass = std::make_shared<SharedPass>(files_, imu_topic, temperature_topic_);
    other = pass;
    return pass;
  }

  std::vector<fs::path> files_;
  std::string temperature_topic_;
  mutable std::weak_ptr<SharedPass> open_imu_, open_temperature_;  // a pass waiting for that topic's cursor
};

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

void import_rosbag2(const fs::path& path, const RosbagOptions& options, Recording& rec, SampleSink& out) {
  require_valid(options, "ROS bag options");
  if (!fs::exists(path)) throw ImportError(path, "path", "no such file or folder");
  const std::vector<fs::path> files = fs::is_directory(path) ? storage_files(path) : std::vector<fs::path>{path};
  if (files.empty()) throw ImportError(path, "folder", "no rosbag2 storage file (expected metadata.yaml, .db3 or MCAP)");
  // The first pass reads every file to the end for its topics (an MCAP file may declare a channel
  // anywhere) and checks its records.
  TopicList topics;
  StorageCursor all(files, &topics);
  for (RawMessage m; all.next(m);) {
  }
  Ros2Reader reader(files, options.temperature_topic);
  reader.imu_topic = choose_imu_topic(path, topics.all(), options, kRos2Types);
  check_temperature_topic(path, topics.all(), options, kRos2Types);
  reader.notes = std::move(all.notes);
  reader.notes.push_back("CDR payloads");
  stream_recording(path, reader, options, rec, out);
}

Recording import_rosbag2(const fs::path& path, const RosbagOptions& options) {
  return detail::import_in_memory([&](Recording& rec, SampleSink& out) { import_rosbag2(path, options, rec, out); });
}

}  // namespace stend::io
