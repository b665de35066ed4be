#include "rosbag_common.hpp"

#include "import_common.hpp"

#include <lz4frame.h>
#include <xxhash.h>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <string>
#include <unordered_set>
#include <utility>

namespace stend::io::rosbag_detail {

namespace fs = std::filesystem;
using namespace detail;

namespace {

std::string list_topics(const std::vector<TopicInfo>& topics) {
  if (topics.empty()) return "the bag has no topics";
  std::string out = "the bag's topics:";
  for (const TopicInfo& t : topics) out += " " + t.name + " (" + t.type + ")";
  return out;
}

const TopicInfo* find_topic(const std::vector<TopicInfo>& topics, const std::string& name) {
  for (const TopicInfo& t : topics) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

// The named topic, checked to carry `type`.
void check_named_topic(const fs::path& file, const std::vector<TopicInfo>& topics,
                       const std::string& name, std::string_view type) {
  const TopicInfo* t = find_topic(topics, name);
  if (!t) throw ImportError(file, "topic " + name, "no such topic (expected " + std::string(type) + "); " + list_topics(topics));
  if (t->type != type) {
    throw ImportError(file, "topic " + name,
                      "type " + t->type + ", expected " + std::string(type) + "; " + list_topics(topics));
  }
}

// What the first pass over the messages finds.
struct BagScan {
  std::size_t imu = 0, temperature = 0;
  std::size_t zero_stamps = 0;         // header stamps that are zero, on both topics
  ImuMessage first;                    // the first Imu message
  std::vector<std::string> frame_ids;  // distinct, in order of appearance
  // Whether the times (header stamps resp. record times) never decrease, over both topics each.
  bool stamps_sorted = true, records_sorted = true;
};

// Whether a sequence of times never decreases.
struct Ordered {
  bool sorted = true;
  bool any = false;
  std::int64_t last = 0;
  void add(std::int64_t t) {
    sorted = sorted && (!any || t >= last);
    any = true;
    last = t;
  }
};

// Both topics in one pass, taken in record-time order, so that their cursors read the same chunk
// at about the same time (a ROS 1 bag decompresses it once for both); each topic's messages in its
// own cursor's order.
BagScan scan_messages(const BagReader& bag) {
  BagScan scan;
  Ordered imu_stamp, imu_record, stamp, record;
  const auto imu = bag.imu();
  const auto temperature = bag.temperature();
  std::unordered_set<std::string> frames;  // scan.frame_ids as a set: a lookup per message, not a scan
  ImuMessage m;
  TemperatureMessage t;
  bool more_imu = imu->next(m), more_temperature = temperature && temperature->next(t);
  while (more_imu || more_temperature) {
    if (more_imu && (!more_temperature || m.record_ns <= t.record_ns)) {
      if (scan.imu == 0) scan.first = m;
      scan.zero_stamps += m.stamp_ns == 0 ? 1 : 0;
      if (frames.insert(m.frame_id).second) scan.frame_ids.push_back(m.frame_id);
      imu_stamp.add(m.stamp_ns);
      imu_record.add(m.record_ns);
      ++scan.imu;
      more_imu = imu->next(m);
    } else {
      scan.zero_stamps += t.stamp_ns == 0 ? 1 : 0;
      stamp.add(t.stamp_ns);
      record.add(t.record_ns);
      ++scan.temperature;
      more_temperature = temperature->next(t);
    }
  }
  scan.stamps_sorted = imu_stamp.sorted && stamp.sorted;
  scan.records_sorted = imu_record.sorted && record.sorted;
  return scan;
}

// The temperature [°C] held at time t [ns]: the latest Temperature message at or before t (the
// first one before it). Pulled from its cursor alongside the Imu messages when both topics are in
// time order (`streamed`; then t must not decrease from call to call), else read whole and sorted.
class HeldTemperature {
 public:
  HeldTemperature(std::unique_ptr<MessageCursor<TemperatureMessage>> cursor, bool use_record_time, bool streamed)
      : cursor_(std::move(cursor)), use_record_time_(use_record_time), streamed_(streamed) {
    if (!cursor_) return;
    if (streamed_) {
      have_next_ = pull(next_);
      held_ = next_.second;
      return;
    }
    for (Timed m; pull(m);) sorted_.push_back(m);
    std::stable_sort(sorted_.begin(), sorted_.end(), [](const Timed& x, const Timed& y) { return x.first < y.first; });
  }
  double at(std::int64_t t_ns) {
    if (streamed_) {
      for (; have_next_ && next_.first <= t_ns; have_next_ = pull(next_)) held_ = next_.second;
      return held_;
    }
    const auto it = std::upper_bound(sorted_.begin(), sorted_.end(), t_ns,
                                     [](std::int64_t t, const Timed& m) { return t < m.first; });
    return it == sorted_.begin() ? sorted_.front().second : std::prev(it)->second;
  }

 private:
  using Timed = std::pair<std::int64_t, double>;  // time [ns], temperature [°C]
  bool pull(Timed& out) {
    TemperatureMessage m;
    if (!cursor_->next(m)) return false;
    out = {use_record_time_ ? m.record_ns : m.stamp_ns, m.celsius};
    return true;
  }
  std::unique_ptr<MessageCursor<TemperatureMessage>> cursor_;
  bool use_record_time_, streamed_;
  bool have_next_ = false;
  Timed next_{0, 0.0};
  double held_ = 0.0;
  std::vector<Timed> sorted_;
};

}  // namespace

// An LZ4 frame (lz4_Frame_format.md): magic 04 22 4D 18, then the FLG byte, whose bit 4 asks for
// a checksum per block and bit 2 for one of the whole content (XXH32, after the end mark). The
// content checksum is verified here with libxxhash rather than by liblz4, whose XXH32 in Debian's
// build (SSE2, the multiplications done by shifts) takes twice as long (64 MiB: 21 against 9.4 ms);
// a frame with block checksums is verified by liblz4 throughout.
std::string decompress_lz4_frame(const std::uint8_t* in, std::uint64_t in_size, std::uint8_t* out, std::uint64_t size) {
  constexpr std::uint8_t kMagic[4] = {0x04, 0x22, 0x4D, 0x18};
  constexpr std::uint8_t kBlockChecksum = 0x10, kContentChecksum = 0x04;
  const bool own_checksum = in_size > 4 && std::equal(kMagic, kMagic + 4, in) && (in[4] & kContentChecksum) &&
                            !(in[4] & kBlockChecksum);
  LZ4F_dctx* ctx = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) return "lz4: no decompression context";
  const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> guard(ctx, LZ4F_freeDecompressionContext);
  LZ4F_decompressOptions_t options{};
  options.stableDst = 1;  // one output buffer for the whole frame: no copies through liblz4's own
  options.skipChecksums = own_checksum ? 1 : 0;
  std::size_t in_pos = 0, out_pos = 0;
  std::size_t hint = 1;
  while (hint != 0 && in_pos < in_size) {
    std::size_t out_n = size - out_pos, in_n = in_size - in_pos;
    hint = LZ4F_decompress(ctx, out + out_pos, &out_n, in + in_pos, &in_n, &options);
    if (LZ4F_isError(hint)) return std::string("lz4 chunk: ") + LZ4F_getErrorName(hint);
    in_pos += in_n;
    out_pos += out_n;
    if (in_n == 0 && out_n == 0) break;
  }
  if (hint != 0 || out_pos != size) return "lz4 chunk does not decompress to its declared size";
  if (own_checksum && XXH32(out, size, 0) != load_le<std::uint32_t>(in + in_pos - 4)) {
    return "lz4 chunk: its content checksum does not match (the chunk is damaged)";
  }
  return {};
}

std::string choose_imu_topic(const fs::path& file, const std::vector<TopicInfo>& topics,
                             const RosbagOptions& options, const MessageTypes& types) {
  if (!options.topic.empty()) {
    check_named_topic(file, topics, options.topic, types.imu);
    return options.topic;
  }
  std::vector<std::string> imu;
  for (const TopicInfo& t : topics) {
    if (t.type == types.imu && std::find(imu.begin(), imu.end(), t.name) == imu.end()) imu.push_back(t.name);
  }
  if (imu.size() == 1) return imu.front();
  if (imu.empty()) throw ImportError(file, "topics", "no " + std::string(types.imu) + " topic; " + list_topics(topics));
  std::string names;
  for (const std::string& n : imu) names += " " + n;
  throw ImportError(file, "topics", std::to_string(imu.size()) + " " + std::string(types.imu) +
                                        " topics:" + names + "; choose one (topic option)");
}

void check_temperature_topic(const fs::path& file, const std::vector<TopicInfo>& topics,
                             const RosbagOptions& options, const MessageTypes& types) {
  if (!options.temperature_topic.empty()) check_named_topic(file, topics, options.temperature_topic, types.temperature);
}

void stream_recording(const fs::path& file, const BagReader& bag, const RosbagOptions& options, Recording& rec,
                      SampleSink& out) {
  const BagScan scan = scan_messages(bag);
  if (scan.imu == 0) throw ImportError(file, "topic " + bag.imu_topic, "no messages on the Imu topic");
  // One time base for both topics: header stamps, unless some are zero (unstamped driver).
  const bool use_record_time = scan.zero_stamps > 0;
  auto time_of = [&](const auto& m) { return use_record_time ? m.record_ns : m.stamp_ns; };
  const std::int64_t t0_ns = time_of(scan.first);
  const bool in_time_order = use_record_time ? scan.records_sorted : scan.stamps_sorted;
  HeldTemperature temperature(bag.temperature(), use_record_time, in_time_order);

  rec = new_recording(file, "rosbag");
  RecordingHeader& h = rec.header;
  h.identity = options.identity;
  if (h.identity.model.empty()) h.identity.model = bag.imu_topic;
  if (h.identity.serial.empty()) h.identity.serial = scan.first.frame_id;
  h.info.has_gyro = true;
  h.info.has_temperature = scan.temperature > 0;
  h.gravity_mps2 = options.gravity_mps2;

  LogTimestampStream times(rec, out);
  SampleChunker chunks(times);
  double t_last_s = 0.0;  // the first sample's time is 0
  const auto imu = bag.imu();
  for (ImuMessage m; imu->next(m);) {
    ImuSample s;
    s.t_s = seconds_since_ns(t0_ns, time_of(m));
    s.accel_mps2 = m.accel_mps2;
    s.gyro_radps = m.gyro_radps;
    if (scan.temperature > 0) s.temperature_c = temperature.at(time_of(m));
    t_last_s = s.t_s;
    chunks.add(s);
  }
  chunks.flush();
  const TimestampSummary sum = times.finish();

  std::string msg = bag.format + " " + file.string() + ": topic " + bag.imu_topic + ", " + std::to_string(scan.imu) +
                    " messages over " + fmt_g(t_last_s) + " s, frame_id '" + scan.first.frame_id + "'";
  if (scan.frame_ids.size() > 1) msg += " (" + std::to_string(scan.frame_ids.size()) + " different frame_ids)";
  msg += use_record_time
             ? "; t_s from the bag's record time, relative to the first message, because " +
                   std::to_string(scan.zero_stamps) + " header stamps are zero (assumed: the recorder received each "
                   "message when it was measured)"
             : "; t_s from header.stamp relative to the first message";
  msg += "; " + sum.rate_and_gaps() + "; " + std::to_string(sum.repeated + sum.decreasing) +
         " timestamps do not increase (kept as recorded)";
  msg += scan.temperature == 0 ? "; no temperature topic"
                               : "; temperature from " + options.temperature_topic + " (" +
                                     std::to_string(scan.temperature) +
                                     " messages, each held until the next; the first one before it" +
                                     (in_time_order ? "" : "; out of time order, so read whole and sorted") + ")";
  msg += "; accel = linear_acceleration [m/s²], gyro = angular_velocity [rad/s] as the message defines "
         "them; orientation and covariances ignored; no raw counts";
  for (const std::string& note : bag.notes) msg += "; " + note;
  add_import_event(rec, msg);
}

}  // namespace stend::io::rosbag_detail

namespace stend::io {

bool RosbagOptions::IsValid(std::string* error) const {
  return gravity_or_unknown(gravity_mps2) ? true : invalid(error, "gravity_mps2 must be >= 0 (0: unknown)");
}

}  // namespace stend::io
