// PX4 ULog import (docs.px4.io "ULog File Format"; pyulog is the reference reader): the IMU
// series chosen from the log's structure (ulog_log.hpp), read a record at a time and merged into
// samples on the accelerometer's times.
#include <stend/io/logs.hpp>

#include "ulog_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <utility>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// ---------------------------------------------------------------------------------------------
// From data records to IMU series

// Reads basic-typed fields of one data record, with bounds checks against the record. The record
// is brought into the reader's buffer on construction; the view is valid until the reader reads
// elsewhere.
class RecordView {
 public:
  RecordView(const BinaryReader& f, const Format& fmt, const DataRecord& r) : f_(f), fmt_(fmt), r_(r) {
    f_.need(r_.offset, r_.size, [this] { return "a '" + fmt_.name + "' data message"; });
  }

  double number(std::string_view name, std::size_t index = 0) const { return number(find_field(fmt_, name), name, index); }
  // Element `index` of field `fld` of the record's format (nullptr: the format has no field `name`).
  double number(const Field* fld, std::string_view name, std::size_t index = 0) const {
    const std::uint8_t* p = at(fld, name, index);
    if (fld->basic == Basic::kNested) {
      f_.fail(r_.offset, "field '" + std::string(name) + "' of '" + fmt_.name + "' is a nested type, expected a number");
    }
    return value_of(fld->basic, p);
  }

  // The record's bytes, unchecked, when it holds at least `size` of them; else nullptr.
  const std::uint8_t* holding(std::size_t size) const { return r_.size >= size ? f_.at(r_.offset) : nullptr; }

  // A basic-typed value at p.
  static double value_of(Basic basic, const std::uint8_t* p) {
    switch (basic) {
      case Basic::kInt8: return load_le<std::int8_t>(p);
      case Basic::kUInt8: case Basic::kBool: case Basic::kChar: return load_le<std::uint8_t>(p);
      case Basic::kInt16: return load_le<std::int16_t>(p);
      case Basic::kUInt16: return load_le<std::uint16_t>(p);
      case Basic::kInt32: return load_le<std::int32_t>(p);
      case Basic::kUInt32: return load_le<std::uint32_t>(p);
      case Basic::kInt64: return static_cast<double>(load_le<std::int64_t>(p));
      case Basic::kUInt64: return static_cast<double>(load_le<std::uint64_t>(p));
      case Basic::kFloat: return static_cast<double>(load_le<float>(p));
      case Basic::kDouble: return load_le<double>(p);
      case Basic::kNested: break;
    }
    return std::numeric_limits<double>::quiet_NaN();
  }

  // A 32-bit device id field; fails when the record holds a value that is not one.
  std::uint32_t id(std::string_view name) const {
    const double v = number(name);
    if (!(v >= 0.0 && v <= 4294967295.0) || v != std::floor(v)) {
      f_.fail(r_.offset, "field '" + std::string(name) + "' of '" + fmt_.name + "' is " + fmt_g(v) + ", not a 32-bit id");
    }
    return static_cast<std::uint32_t>(v);
  }

  // `base` [us] moved by `offset` [us], read from field `name` (a relative timestamp, int32 in
  // PX4's messages); fails when that is not a 32-bit offset or moves the time out of 0 … 2^64 µs.
  std::uint64_t shifted(std::uint64_t base, double offset, std::string_view name) const {
    constexpr double kMin = std::numeric_limits<std::int32_t>::min(), kMax = std::numeric_limits<std::int32_t>::max();
    const bool offset_ok = offset >= kMin && offset <= kMax && offset == std::floor(offset);
    const auto magnitude = offset_ok ? static_cast<std::uint64_t>(std::fabs(offset)) : 0;
    if (!offset_ok || (offset < 0 && base < magnitude) ||
        (offset > 0 && base > std::numeric_limits<std::uint64_t>::max() - magnitude)) {
      f_.fail(r_.offset, "field '" + std::string(name) + "' of '" + fmt_.name + "' is " + fmt_g(offset) +
                             ", not a 32-bit offset from the record's timestamp " + std::to_string(base) + " us");
    }
    return offset < 0 ? base - magnitude : base + magnitude;
  }

  std::uint64_t timestamp(const Field* fld, std::string_view name) const {
    const std::uint8_t* p = at(fld, name, 0);
    if (fld->basic != Basic::kUInt64) {
      f_.fail(fmt_.defined_at, "field '" + std::string(name) + "' of '" + fmt_.name + "' is " + fld->type +
                                   ", expected uint64_t [us]");
    }
    return load_le<std::uint64_t>(p);
  }

 private:
  // The bytes of element `index` of `fld` in this record, checked: the field exists, has that
  // element, and the record holds it.
  const std::uint8_t* at(const Field* fld, std::string_view name, std::size_t index) const {
    if (!fld || index >= fld->count) {
      f_.fail(fmt_.defined_at, "format '" + fmt_.name + "' has no field '" + std::string(name) + "'" +
                                   (index ? "[" + std::to_string(index) + "]" : std::string()));
    }
    if (fld->offset + (index + 1) * fld->element_size > r_.size) {
      f_.fail(r_.offset, "'" + fmt_.name + "' data of " + std::to_string(r_.size) + " bytes ends before field '" +
                             std::string(name) + "' (bytes " + std::to_string(fld->offset) + "…" +
                             std::to_string(fld->offset + (index + 1) * fld->element_size) + ")");
    }
    return f_.at(r_.offset + fld->offset + index * fld->element_size);
  }

  const BinaryReader& f_;
  const Format& fmt_;
  const DataRecord r_;
};

// The msg_ids of a topic instance, ascending.
std::vector<std::uint16_t> subscription_ids(const UlogLog& log, const std::string& topic, int instance) {
  std::vector<std::uint16_t> out;
  for (const auto& [id, sub] : log.subscriptions) {
    if (sub.topic == topic && sub.instance == instance) out.push_back(id);
  }
  return out;
}

// The data records of a topic instance's subscriptions (one msg_id, or more where it was logged
// again) in file order, read through a reader of its own: the second pass, decoding only these.
// (A pass per msg_id, one subscription after the other, made a crafted log of many subscriptions of
// one topic quadratic: 18 s for 16 000.)
class RecordCursor {
 public:
  RecordCursor(const fs::path& file, const UlogLog& log, std::vector<std::uint16_t> ids)
      : f_(file), log_(&log), ids_(std::move(ids)) {}
  const BinaryReader& reader() const { return f_; }
  // The next record and the losses before it; false after the last.
  bool next(DataRecord& r, std::size_t& lost_before) {
    Message m{};
    while (next_message(f_, log_->appended_offsets, pos_, losses_, m)) {
      if (m.type != 'D' || m.size < 2 ||
          !std::binary_search(ids_.begin(), ids_.end(), f_.get<std::uint16_t>(m.body, "a data msg_id")))
        continue;
      r = DataRecord{m.body + 2, m.size - 2};
      lost_before = losses_.lost;
      return true;
    }
    return false;
  }

 private:
  BinaryReader f_;
  const UlogLog* log_;
  std::vector<std::uint16_t> ids_;  // ascending
  std::size_t pos_ = kUlogHeaderBytes;
  Losses losses_;
};

// One sample of a series: time [µs], vector (m/s² or rad/s), temperature [°C] (when the topic has
// one), the losses before it, its index in the series.
struct Point {
  std::uint64_t t_us = 0;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  double temperature_c = 0.0;
  std::size_t lost_before = 0;
  std::size_t index = 0;
};

// Which part of a topic's records a series is.
enum class Part {
  kSensor,          // sensor_accel / sensor_gyro: x y z, temperature, time timestamp_sample (else timestamp)
  kCombinedAccel,   // sensor_combined: accelerometer_m_s2 at timestamp + accelerometer_timestamp_relative
                    // (records marked invalid skipped)
  kCombinedGyro,    // sensor_combined: gyro_rad at timestamp
};

// One sensor's samples in file order, decoded a record at a time; the fields it reads are looked
// up in the format once (a record missing one fails when it is read, naming the field).
class SeriesReader {
 public:
  SeriesReader(const fs::path& file, const UlogLog& log, std::string topic_name, int instance, Part part)
      : topic(std::move(topic_name)), cursor_(file, log, subscription_ids(log, topic, instance)),
        fmt_(&log.formats.at(topic)), part_(part) {
    what = topic + " instance " + std::to_string(instance) +
           (part == Part::kCombinedAccel ? " accelerometer_m_s2" : part == Part::kCombinedGyro ? " gyro_rad" : "");
    has_temperature = part == Part::kSensor && find_field(*fmt_, "temperature") != nullptr;
    const bool sample_time = part == Part::kSensor && find_field(*fmt_, "timestamp_sample");
    time_ = named(sample_time ? "timestamp_sample" : "timestamp");
    temperature_ = named("temperature");
    relative_ = named("accelerometer_timestamp_relative");
    constexpr const char* kAxes[] = {"x", "y", "z"};
    for (std::size_t k = 0; k < 3; ++k) {
      vector_[k] = part == Part::kSensor        ? named(kAxes[k])
                   : part == Part::kCombinedGyro ? named("gyro_rad", k)
                                                 : named("accelerometer_m_s2", k);
    }
    direct_bytes_ = direct_size();
  }
  std::string topic, what;  // "sensor_accel", "sensor_accel instance 1"
  bool has_temperature = false;
  std::size_t count() const { return count_; }  // points read so far

  bool next(Point& p) {
    DataRecord r{};
    while (cursor_.next(r, p.lost_before)) {
      const RecordView v(cursor_.reader(), *fmt_, r);
      const std::uint8_t* bytes = v.holding(direct_bytes_);  // every field there: read directly
      const bool kept =
          bytes ? decode(v, load_le<std::uint64_t>(bytes + time_.offset), [&](const Named& n) { return value(bytes, n); }, p)
                : decode(v, v.timestamp(time_.field, time_.name), [&](const Named& n) { return number(v, n); }, p);
      if (!kept) continue;
      p.index = count_++;
      return true;
    }
    return false;
  }

 private:
  // A field of the format by name (nullptr when it has none), which element of it, and where that
  // element lies in a record.
  struct Named {
    const Field* field = nullptr;
    std::string_view name;
    std::size_t index = 0;
    std::size_t offset = 0, end = 0;  // bytes [offset, end) of the record
  };
  Named named(std::string_view name, std::size_t index = 0) const {
    Named n{find_field(*fmt_, name), name, index};
    if (n.field) {
      n.offset = n.field->offset + index * n.field->element_size;
      n.end = n.offset + n.field->element_size;
    }
    return n;
  }
  static double number(const RecordView& v, const Named& n) { return v.number(n.field, n.name, n.index); }
  static double value(const std::uint8_t* bytes, const Named& n) {
    return RecordView::value_of(n.field->basic, bytes + n.offset);
  }

  // The record size from which every field this series reads can be read directly: each exists,
  // holds the element asked for, is a number (the time a uint64_t); kNoDirect when one does not
  // (every record is then read through the checks, which name what is wrong).
  static constexpr std::size_t kNoDirect = std::numeric_limits<std::size_t>::max();
  std::size_t direct_size() const {
    std::vector<const Named*> used = {&time_, &vector_[0], &vector_[1], &vector_[2]};
    if (has_temperature) used.push_back(&temperature_);
    if (part_ == Part::kCombinedAccel) used.push_back(&relative_);
    std::size_t size = 0;
    for (const Named* n : used) {
      if (!n->field || n->index >= n->field->count || n->field->basic == Basic::kNested) return kNoDirect;
      size = std::max(size, n->end);
    }
    return time_.field->basic == Basic::kUInt64 ? size : kNoDirect;
  }

  // A record's point from its time [µs] and its fields' values as `get` reads them (directly, or
  // through the checks); false when the record is to be skipped.
  template <class Get>
  bool decode(const RecordView& v, std::uint64_t t_us, const Get& get, Point& p) const {
    p.t_us = t_us;
    if (part_ == Part::kCombinedAccel) {
      const double rel = get(relative_);
      if (rel == kRelativeTimestampInvalid) return false;
      p.t_us = v.shifted(p.t_us, rel, relative_.name);
    }
    p.v = Eigen::Vector3d(get(vector_[0]), get(vector_[1]), get(vector_[2]));
    if (has_temperature) p.temperature_c = get(temperature_);
    return true;
  }

  RecordCursor cursor_;
  const Format* fmt_;
  Part part_;
  Named time_, temperature_, relative_, vector_[3];
  std::size_t direct_bytes_ = kNoDirect;
  std::size_t count_ = 0;
};

// Number of data records per instance of a topic.
std::map<int, std::size_t> instance_counts(const UlogLog& log, const std::string& topic) {
  std::map<int, std::size_t> out;
  for (const auto& [id, sub] : log.subscriptions) {
    if (sub.topic == topic) out[sub.instance] += sub.records;
  }
  return out;
}

// The first data record of a topic's instance in the file, if any.
std::optional<DataRecord> first_record(const UlogLog& log, const std::string& topic, int instance) {
  std::optional<DataRecord> first;
  for (const std::uint16_t id : subscription_ids(log, topic, instance)) {
    const std::optional<DataRecord>& r = log.subscriptions.at(id).first;
    if (r && (!first || r->offset < first->offset)) first = r;
  }
  return first;
}

std::string describe_counts(const std::string& topic, const std::map<int, std::size_t>& counts) {
  std::string s;
  for (const auto& [inst, n] : counts) {
    s += (s.empty() ? "" : ", ") + topic + " instance " + std::to_string(inst) + ": " + std::to_string(n);
  }
  return s.empty() ? topic + ": none" : s;
}

// The instance asked for (it must exist), else the one with the most records.
int choose_instance(const std::map<int, std::size_t>& counts, int wanted) {
  if (wanted >= 0) return counts.count(wanted) ? wanted : -1;
  int best = -1;
  std::size_t most = 0;
  for (const auto& [inst, n] : counts) {
    if (n > most) best = inst, most = n;
  }
  return best;
}

// What an import reads: the accelerometer and gyro series, their device ids, and why they were
// chosen.
struct UlogChoice {
  std::string topic;  // "sensor_accel" (with sensor_gyro) or "sensor_combined"
  int instance = 0;
  std::optional<std::uint32_t> acc_device_id, gyr_device_id;
  int temperature_instance = -1;  // sensor_combined: a sensor_accel instance of the same device
  std::string why;
  std::string temperature_note;
};

// device_id of a sensor topic's instance (its first record), if the topic has one.
std::optional<std::uint32_t> device_id(const BinaryReader& f, const UlogLog& log, const std::string& topic, int instance) {
  const Format& fmt = log.formats.at(topic);
  const auto r = first_record(log, topic, instance);
  if (!r || !find_field(fmt, "device_id")) return std::nullopt;
  return RecordView(f, fmt, *r).id("device_id");
}

// sensor_combined: the devices sensor_selection names (its first message) as the accel's and
// gyro's device ids, and the sensor_accel instance with that device id and a temperature.
void add_selected_devices(const BinaryReader& f, const UlogLog& log, UlogChoice& c) {
  const auto sel = std::find_if(log.subscriptions.begin(), log.subscriptions.end(), [](const auto& s) {
    return s.second.topic == "sensor_selection" && s.second.first;
  });
  const Format* fmt = sel == log.subscriptions.end() ? nullptr : &log.formats.at("sensor_selection");
  if (!fmt || !find_field(*fmt, "accel_device_id") || !find_field(*fmt, "gyro_device_id")) {
    c.temperature_note = "no temperature (sensor_combined has none, and no sensor_selection names its devices)";
    return;
  }
  {
    const RecordView v(f, *fmt, *sel->second.first);
    c.acc_device_id = v.id("accel_device_id");
    c.gyr_device_id = v.id("gyro_device_id");
  }
  const bool has_temperature = log.formats.count("sensor_accel") &&
                               find_field(log.formats.at("sensor_accel"), "temperature") != nullptr;
  for (const auto& [inst, n] : instance_counts(log, "sensor_accel")) {
    if (n > 0 && has_temperature && device_id(f, log, "sensor_accel", inst) == c.acc_device_id) {
      c.temperature_note = "temperature interpolated from sensor_accel instance " + std::to_string(inst) +
                           " (the device sensor_selection names)";
      c.temperature_instance = inst;
      return;
    }
  }
  c.temperature_note = "no temperature (no sensor_accel of the selected device " + fmt_hex(*c.acc_device_id, 8) + ")";
}

UlogChoice choose_series(const BinaryReader& f, const UlogLog& log, const UlogOptions& opt) {
  const auto accel = instance_counts(log, "sensor_accel");
  const auto gyro = instance_counts(log, "sensor_gyro");
  const auto combined = instance_counts(log, "sensor_combined");
  const std::string available = describe_counts("sensor_accel", accel) + "; " + describe_counts("sensor_gyro", gyro) +
                                "; " + describe_counts("sensor_combined", combined);
  const int ag = choose_instance(accel, opt.instance);
  const int cb = choose_instance(combined, opt.instance);
  const std::size_t ag_n = ag >= 0 && gyro.count(ag) && gyro.at(ag) > 0 ? accel.at(ag) : 0;
  const std::size_t cb_n = cb >= 0 ? combined.at(cb) : 0;
  bool use_ag = false;
  std::string why;
  switch (opt.source) {
    case UlogSource::kSensorAccelGyro: use_ag = true; why = "topics as asked"; break;
    case UlogSource::kSensorCombined: use_ag = false; why = "topic as asked"; break;
    case UlogSource::kAuto:
      use_ag = ag_n > 0 && 2 * ag_n >= cb_n;
      why = use_ag ? "it holds at least half as many samples as sensor_combined"
                   : "sensor_accel + sensor_gyro hold fewer than half as many samples (logged sparsely)";
      break;
  }
  const std::string which = opt.instance >= 0 ? "instance " + std::to_string(opt.instance) + " as asked"
                                              : "the instance with the most samples";
  if ((use_ag && ag_n == 0) || (!use_ag && cb_n == 0)) {
    f.fail(f.size(), std::string("no IMU data: expected ") +
                         (use_ag ? "sensor_accel and sensor_gyro" : opt.source == UlogSource::kAuto
                                                                         ? "sensor_accel + sensor_gyro or sensor_combined"
                                                                         : "sensor_combined") +
                         " data (" + which + "); the log has " + available);
  }
  UlogChoice c;
  c.topic = use_ag ? "sensor_accel" : "sensor_combined";
  c.instance = use_ag ? ag : cb;
  if (use_ag) {
    c.acc_device_id = device_id(f, log, "sensor_accel", ag);
    c.gyr_device_id = device_id(f, log, "sensor_gyro", ag);
  } else {
    add_selected_devices(f, log, c);
  }
  c.why = "IMU from " + std::string(use_ag ? "sensor_accel + sensor_gyro" : "sensor_combined") + " instance " +
          std::to_string(c.instance) + " (" + which + "; " + why + "); available: " + available;
  return c;
}

SeriesReader accel_series(const fs::path& file, const UlogLog& log, const UlogChoice& c) {
  return {file, log, c.topic, c.instance, c.topic == "sensor_accel" ? Part::kSensor : Part::kCombinedAccel};
}
SeriesReader gyro_series(const fs::path& file, const UlogLog& log, const UlogChoice& c) {
  if (c.topic == "sensor_accel") return {file, log, "sensor_gyro", c.instance, Part::kSensor};
  return {file, log, c.topic, c.instance, Part::kCombinedGyro};
}

constexpr double kTimestampUnitS = 1e-6;     // interpolation tolerance at the ends: one timestamp unit
constexpr double kTemperatureHoldS = 2.0;    // a sparse temperature is held this long past its ends

// Linear interpolation over a series read in file order, as interpolate_at over the whole series
// sorted by time, through a bounded window: points are read kLookAhead past the time asked
// (inserted in time order, so that timestamps out of order by fewer points are sorted as a
// whole-series sort would), and kHistory points at or before it are kept (the times asked may step
// back that far). The series' time span [min, max] is that of the points read; once they are all
// read, exactly the whole series'.
template <class V>
class StreamInterpolation {
 public:
  static constexpr std::size_t kLookAhead = 64, kHistory = 64;  // [points]
  // The most points held: a crafted series (every time equal, or all of it before the other
  // series' first time) was read whole into the window, each point inserted or searched for across
  // it — quadratic (35 s for 320 000 points).
  static constexpr std::size_t kMaxWindow = 4096;

  StreamInterpolation(SeriesReader& series, std::uint64_t t0_us, double tol_s, V (*value)(const Point&))
      : series_(&series), t0_us_(t0_us), tol_s_(tol_s), value_(value) {}

  // The value at t_s [s from t0]; false outside the series' span widened by the tolerance.
  bool at(double t_s, V& out) {
    fill(t_s);
    if (t_.empty() || t_s < min_s_ - tol_s_ || (done_ && t_s > max_s_ + tol_s_)) return false;
    interpolate_at(t_, v_, t_s, std::numeric_limits<double>::infinity(), out);
    trim(t_s);
    return true;
  }

  // The value of the series' point `index` when it is logged at t_s (one series paired with
  // another sample by sample), if it is.
  std::optional<V> paired(std::size_t index, double t_s) {
    if (t_.size() >= kMaxWindow) drop_before(index);  // no later call asks for those
    fill(t_s);
    // The points logged at t_s are in index order (each inserted after the equal ones before it).
    const auto lo = std::lower_bound(t_.begin(), t_.end(), t_s) - t_.begin();
    const auto hi = std::upper_bound(t_.begin(), t_.end(), t_s) - t_.begin();
    const auto k = std::lower_bound(index_.begin() + lo, index_.begin() + hi, index) - index_.begin();
    if (k < hi && index_[static_cast<std::size_t>(k)] == index) return v_[static_cast<std::size_t>(k)];
    return std::nullopt;
  }

 private:
  void fill(double t_s) {
    while (!done_ && t_.size() < kMaxWindow &&
           static_cast<std::size_t>(t_.end() - std::upper_bound(t_.begin(), t_.end(), t_s)) < kLookAhead) {
      Point p;
      if (!series_->next(p)) {
        done_ = true;
        break;
      }
      const double t = seconds_since_us(t0_us_, p.t_us);
      min_s_ = std::min(min_s_, t);
      max_s_ = std::max(max_s_, t);
      const auto at = static_cast<std::ptrdiff_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin());
      t_.insert(t_.begin() + at, t);
      v_.insert(v_.begin() + at, value_(p));
      index_.insert(index_.begin() + at, p.index);
      drop_first(static_cast<std::size_t>(std::lower_bound(t_.begin(), t_.end(), t_s) - t_.begin()));
    }
  }
  // Drops the points more than kHistory before t_s (in batches of kHistory, to move the window rarely).
  void trim(double t_s) {
    drop_first(static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t_s) - t_.begin()));
  }
  // Of the first `before` points, drops all but the last kHistory once they are 2·kHistory or more.
  // While filling, `before` counts the points strictly before the time asked for: neither its
  // interpolation nor a pairing at that time needs them.
  void drop_first(std::size_t before) {
    if (before < 2 * kHistory) return;
    const auto n = static_cast<std::ptrdiff_t>(before - kHistory);
    t_.erase(t_.begin(), t_.begin() + n);
    v_.erase(v_.begin(), v_.begin() + n);
    index_.erase(index_.begin(), index_.begin() + n);
  }
  // Drops the points before `index` in the series.
  void drop_before(std::size_t index) {
    std::size_t kept = 0;
    for (std::size_t k = 0; k < t_.size(); ++k) {
      if (index_[k] < index) continue;
      t_[kept] = t_[k];
      v_[kept] = v_[k];
      index_[kept] = index_[k];
      ++kept;
    }
    t_.resize(kept);
    v_.resize(kept);
    index_.resize(kept);
  }

  SeriesReader* series_;
  std::uint64_t t0_us_;
  double tol_s_;
  V (*value_)(const Point&);
  std::vector<double> t_;
  std::vector<V> v_;
  std::vector<std::size_t> index_;
  double min_s_ = std::numeric_limits<double>::infinity(), max_s_ = -std::numeric_limits<double>::infinity();
  bool done_ = false;
};

Eigen::Vector3d vector_of(const Point& p) { return p.v; }
double temperature_of(const Point& p) { return p.temperature_c; }

// Time span [s from t0] of a series: [min, max] of its times, and of those inside `within` when given.
struct Span {
  double min = std::numeric_limits<double>::infinity(), max = -std::numeric_limits<double>::infinity();
  bool contains(double t, double tol) const { return t >= min - tol && t <= max + tol; }
};
Span span_of(SeriesReader&& s, std::uint64_t t0_us, const Span* within = nullptr, double within_tol = 0.0) {
  Span out;
  Point p;
  while (s.next(p)) {
    const double t = seconds_since_us(t0_us, p.t_us);
    if (within && !within->contains(t, within_tol)) continue;
    out.min = std::min(out.min, t);
    out.max = std::max(out.max, t);
  }
  return out;
}

// sensor_combined: whether the sparse temperature series covers every sample that is kept (those
// inside the gyro's span) within kTemperatureHoldS — a pass over the three series' times. The
// temperature is interpolated for all samples or for none.
bool temperature_covers(const fs::path& file, const UlogLog& log, const UlogChoice& c, std::uint64_t t0_us) {
  const Span gyro = span_of(gyro_series(file, log, c), t0_us);
  const Span kept = span_of(accel_series(file, log, c), t0_us, &gyro, kTimestampUnitS);
  const Span temp = span_of(SeriesReader(file, log, "sensor_accel", c.temperature_instance, Part::kSensor), t0_us);
  return kept.min > kept.max || (temp.contains(kept.min, kTemperatureHoldS) && temp.contains(kept.max, kTemperatureHoldS));
}

// What the merge did, for the info event.
struct MergeSummary {
  std::size_t samples = 0, dropped = 0, lost_gaps = 0;
  std::string note;
};

// Samples at the accelerometer times [s from the first accelerometer sample], a chunk at a time to
// `out`: accel [m/s²], temperature [°C], gyro [rad/s] as logged at the same time (the gyro sample
// of the same index with the same timestamp) or linearly interpolated; a dropout or resync before
// a sample flags a gap. Accelerometer samples outside the gyro's time span are dropped. Sets
// has_temperature before the first sample goes out.
MergeSummary merge_series(const BinaryReader& f, const UlogLog& log, const UlogChoice& c, Recording& rec,
                          SampleSink& out) {
  SeriesReader acc = accel_series(f.file(), log, c), gyr = gyro_series(f.file(), log, c);
  const std::size_t gyro_count = instance_counts(log, gyr.topic)[c.instance];
  Point a;
  const bool any = acc.next(a);
  if (!any || gyro_count == 0) {
    f.fail(f.size(), "no IMU data: " + acc.what + " has " + std::to_string(any ? acc.count() : 0) + " samples, " +
                         gyr.what + " " + std::to_string(gyro_count));
  }
  const std::uint64_t t0 = a.t_us;
  StreamInterpolation<Eigen::Vector3d> gyro(gyr, t0, kTimestampUnitS, vector_of);
  MergeSummary m;
  std::optional<SeriesReader> temp_series;
  std::optional<StreamInterpolation<double>> temp;
  std::string temperature_note = c.temperature_note;
  rec.header.info.has_temperature = acc.has_temperature;
  if (acc.has_temperature) {
    temperature_note = "temperature from " + acc.what;
  } else if (c.temperature_instance >= 0 && !temperature_covers(f.file(), log, c, t0)) {
    temperature_note = "no temperature (sensor_accel instance " + std::to_string(c.temperature_instance) +
                       " does not cover the samples within " + fmt_g(kTemperatureHoldS) + " s)";
  } else if (c.temperature_instance >= 0) {
    temp_series.emplace(f.file(), log, "sensor_accel", c.temperature_instance, Part::kSensor);
    temp.emplace(*temp_series, t0, kTemperatureHoldS, temperature_of);
    rec.header.info.has_temperature = true;
    temperature_note += ", held at its end values up to " + fmt_g(kTemperatureHoldS) + " s beyond";
  }
  std::vector<ImuSample> chunk;
  chunk.reserve(kDefaultChunkSamples);
  bool same_times = true;
  std::size_t prev_lost = a.lost_before;
  do {
    ImuSample s;
    s.t_s = seconds_since_us(t0, a.t_us);
    s.accel_mps2 = a.v;
    if (acc.has_temperature) s.temperature_c = a.temperature_c;
    const bool lost = a.index > 0 && a.lost_before != prev_lost;
    prev_lost = a.lost_before;
    if (const auto logged = gyro.paired(a.index, s.t_s)) {
      s.gyro_radps = *logged;
    } else {
      same_times = false;
      if (!gyro.at(s.t_s, s.gyro_radps)) {
        ++m.dropped;
        continue;
      }
    }
    if (temp) temp->at(s.t_s, s.temperature_c);
    if (lost) s.flags |= kGapBefore, ++m.lost_gaps;
    chunk.push_back(s);
    if (chunk.size() == kDefaultChunkSamples) {
      out.add_samples(chunk.data(), chunk.size());
      m.samples += chunk.size();
      chunk.clear();
    }
  } while (acc.next(a));
  out.add_samples(chunk.data(), chunk.size());
  m.samples += chunk.size();
  if (m.samples == 0) {
    f.fail(f.size(), "the gyro's timestamps do not overlap the accelerometer's (" + acc.what + ", " + gyr.what + ")");
  }
  same_times = same_times && acc.count() == gyro_count;
  m.note = (same_times ? "gyro logged at the accelerometer times"
                       : "gyro linearly interpolated at the accelerometer times" +
                             (m.dropped ? " (" + std::to_string(m.dropped) +
                                              " accelerometer sample(s) outside the gyro's time span dropped)"
                                        : std::string())) +
           "; " + temperature_note;
  return m;
}

std::string info_or(const UlogLog& log, const std::string& key, const std::string& fallback = {}) {
  const auto it = log.info.find(key);
  return it == log.info.end() ? fallback : it->second;
}

// Identity from the info messages: sys_name (vendor), ver_hw (model), sys_uuid (serial) and the
// PX4 device ids of the chosen sensors (who_am_i).
SensorIdentity ulog_identity(const UlogLog& log, const UlogChoice& c) {
  SensorIdentity id;
  id.vendor = info_or(log, "sys_name");
  id.model = info_or(log, "ver_hw");
  id.serial = info_or(log, "sys_uuid");
  if (c.acc_device_id) id.who_am_i = "accel device_id " + fmt_hex(*c.acc_device_id, 8);
  if (c.gyr_device_id) id.who_am_i += (id.who_am_i.empty() ? "" : ", ") + std::string("gyro device_id ") + fmt_hex(*c.gyr_device_id, 8);
  return id;
}

}  // namespace

// Two passes over the file through bounded buffers: the first reads every message header (the
// definitions, info, and how many data messages each subscription holds), the second decodes the
// chosen series' records (accelerometer and gyro, each with a reader of its own) into samples.
bool UlogOptions::IsValid(std::string* error) const {
  if (source != UlogSource::kAuto && source != UlogSource::kSensorAccelGyro && source != UlogSource::kSensorCombined)
    return invalid(error, "unknown source");
  return instance >= -1 ? true : invalid(error, "instance must be >= 0, or -1 (the instance with the most samples)");
}

void import_ulog(const fs::path& file, const UlogOptions& opt, Recording& rec, SampleSink& out) {
  require_valid(opt, "ULog options");
  const BinaryReader f(file);
  const UlogLog log = read_ulog(f);
  const UlogChoice choice = choose_series(f, log, opt);
  rec = new_recording(file, "ulog");
  SensorInfo& info = rec.header.info;
  info.has_gyro = true;
  rec.header.identity = ulog_identity(log, choice);
  LogTimestampStream times(rec, out);
  const MergeSummary merge = merge_series(f, log, choice, rec, times);
  const TimestampSummary ts = times.finish();
  add_import_event(
      rec, "imported " + std::to_string(merge.samples) + " samples from " + file.string() + " (PX4 ULog; " +
               "sys_name '" + info_or(log, "sys_name", "?") + "', ver_hw '" + info_or(log, "ver_hw", "?") +
               "', ver_sw '" + info_or(log, "ver_sw", "?") + "'; " + choice.why + "; " + merge.note +
               "; values as logged: m/s^2, rad/s, degC" +
               "; t = " + (choice.topic == "sensor_combined" ? "timestamp + accelerometer_timestamp_relative"
                                                              : "timestamp_sample") +
               " [us] relative to the first sample; " + ts.describe() + "; " + std::to_string(log.dropouts) +
               " dropout(s) (" + std::to_string(log.dropout_ms) + " ms) and " + std::to_string(log.losses.resyncs) +
               " resync(s) (" + std::to_string(log.losses.skipped_bytes) + " bytes skipped) flagged " +
               std::to_string(merge.lost_gaps) + " gap(s); " + std::to_string(log.parameters) + " parameters not imported)");
  if (!log.losses.cut_what.empty()) add_import_event(rec, file.string() + ": " + log.losses.describe_cut(f.size()), "warning");
}

Recording import_ulog(const fs::path& file, const UlogOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_ulog(file, opt, rec, out); });
}

}  // namespace stend::io
