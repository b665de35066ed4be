#include "rosbag_common.hpp"

#include "import_common.hpp"

#include <algorithm>
#include <cstddef>
#include <string>
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

// Nanoseconds since the first message → seconds (the difference is exact in int64).
double seconds_since(std::int64_t t_ns, std::int64_t t0_ns) { return 1e-9 * static_cast<double>(t_ns - t0_ns); }

// The temperature [°C] held at time t [ns]: the latest message at or before t (times sorted), the
// first one before it.
double held_temperature(const std::vector<std::pair<std::int64_t, double>>& sorted, std::int64_t t_ns) {
  auto it = std::upper_bound(sorted.begin(), sorted.end(), t_ns,
                             [](std::int64_t t, const std::pair<std::int64_t, double>& m) { return t < m.first; });
  return it == sorted.begin() ? sorted.front().second : std::prev(it)->second;
}

std::size_t count_zero_stamps(const BagContent& c) {
  std::size_t n = 0;
  for (const ImuMessage& m : c.imu) n += m.stamp_ns == 0 ? 1 : 0;
  for (const TemperatureMessage& m : c.temperature) n += m.stamp_ns == 0 ? 1 : 0;
  return n;
}

std::size_t count_non_increasing(const std::vector<ImuSample>& s) {
  std::size_t n = 0;
  for (std::size_t i = 1; i < s.size(); ++i) n += s[i].t_s <= s[i - 1].t_s ? 1 : 0;
  return n;
}

std::size_t count_frame_ids(const BagContent& c) {
  std::vector<std::string> ids;
  for (const ImuMessage& m : c.imu) {
    if (std::find(ids.begin(), ids.end(), m.frame_id) == ids.end()) ids.push_back(m.frame_id);
  }
  return ids.size();
}

}  // namespace

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

Recording make_recording(const fs::path& file, const BagContent& c, const RosbagOptions& options) {
  if (c.imu.empty()) throw ImportError(file, "topic " + c.imu_topic, "no messages on the Imu topic");
  // One time base for both topics: header stamps, unless some are zero (unstamped driver).
  const std::size_t zero_stamps = count_zero_stamps(c);
  const bool use_record_time = zero_stamps > 0;
  auto time_of = [&](const auto& m) { return use_record_time ? m.record_ns : m.stamp_ns; };
  const std::int64_t t0_ns = time_of(c.imu.front());

  std::vector<std::pair<std::int64_t, double>> temps;
  for (const TemperatureMessage& m : c.temperature) temps.emplace_back(time_of(m), m.celsius);
  std::stable_sort(temps.begin(), temps.end(), [](const auto& a, const auto& b) { return a.first < b.first; });

  Recording rec = new_recording(file, "rosbag");
  rec.samples.reserve(c.imu.size());
  for (const ImuMessage& m : c.imu) {
    ImuSample s;
    s.t_s = seconds_since(time_of(m), t0_ns);
    s.accel_mps2 = m.accel_mps2;
    s.gyro_radps = m.gyro_radps;
    if (!temps.empty()) s.temperature_c = held_temperature(temps, time_of(m));
    rec.samples.push_back(s);
  }
  const double median_dt = median_interval(rec.samples);
  const double rate_hz = median_dt > 0.0 ? 1.0 / median_dt : 0.0;
  const std::size_t gaps = flag_time_gaps(rec.samples, rate_hz);
  const std::size_t non_increasing = count_non_increasing(rec.samples);

  RecordingHeader& h = rec.header;
  h.identity = options.identity;
  if (h.identity.model.empty()) h.identity.model = c.imu_topic;
  if (h.identity.serial.empty()) h.identity.serial = c.imu.front().frame_id;
  h.info.output_rate_hz = rate_hz;
  h.info.has_gyro = true;
  h.info.has_temperature = !temps.empty();
  h.gravity_mps2 = options.gravity_mps2;

  const double duration_s = rec.samples.back().t_s - rec.samples.front().t_s;
  std::string msg = c.format + " " + file.string() + ": topic " + c.imu_topic + ", " +
                    std::to_string(c.imu.size()) + " messages over " + fmt_g(duration_s) + " s, frame_id '" +
                    c.imu.front().frame_id + "'";
  if (const std::size_t ids = count_frame_ids(c); ids > 1) msg += " (" + std::to_string(ids) + " different frame_ids)";
  msg += use_record_time
             ? "; t_s from the bag's record time, relative to the first message, because " +
                   std::to_string(zero_stamps) + " header stamps are zero (assumed: the recorder received each "
                   "message when it was measured)"
             : "; t_s from header.stamp relative to the first message";
  msg += "; rate " + fmt_g(rate_hz) + " Hz from the median interval; " + std::to_string(gaps) +
         " gaps (> 1.5 intervals) flagged; " + std::to_string(non_increasing) +
         " timestamps do not increase (kept as recorded)";
  msg += temps.empty() ? "; no temperature topic"
                       : "; temperature from " + options.temperature_topic + " (" + std::to_string(temps.size()) +
                             " messages, each held until the next; the first one before it)";
  msg += "; accel = linear_acceleration [m/s²], gyro = angular_velocity [rad/s] as the message defines "
         "them; orientation and covariances ignored; no raw counts";
  for (const std::string& note : c.notes) msg += "; " + note;
  add_import_event(rec, msg);
  return rec;
}

}  // namespace stend::io::rosbag_detail
