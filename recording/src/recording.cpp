// The recording's vocabulary: run status, store format and segment kind with one name table each,
// Segment's print/equals, and Recording's views of its samples and truth. The writer is in
// recording_writer.cpp, the reader in recording_reader.cpp.
#include "stend/recording/recording.hpp"

#include "csv_run_store.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ostream>

namespace stend {

const SampleSource& Recording::sample_source() const {
  if (source) return *source;
  if (!memory_view_ || &memory_view_->samples() != &samples)
    memory_view_ = std::make_shared<MemorySamples>(samples);
  return *memory_view_;
}

std::shared_ptr<const RecordedTruth> Recording::recorded_truth() const {
  if (truth_store) return truth_store;
  return std::make_shared<MemoryTruth>(truth_t, truth, header.truth_columns.size());
}

int Recording::truth_column(const std::string& name) const {
  const auto& c = header.truth_columns;
  const auto it = std::find(c.begin(), c.end(), name);
  return it == c.end() ? -1 : static_cast<int>(it - c.begin());
}

const char* to_string(RunStatus s) {
  switch (s) {
    case RunStatus::kRunning: return "running";
    case RunStatus::kComplete: return "complete";
    case RunStatus::kInterrupted: return "interrupted";
    case RunStatus::kFailed: return "failed";
  }
  return "?";
}

std::optional<RunStatus> run_status_from_string(std::string_view name) {
  for (RunStatus s : {RunStatus::kRunning, RunStatus::kComplete, RunStatus::kInterrupted, RunStatus::kFailed})
    if (name == to_string(s)) return s;
  return std::nullopt;
}

std::ostream& operator<<(std::ostream& os, RunStatus s) { return os << to_string(s); }

const char* to_string(RecordingFormat f) { return f == RecordingFormat::kHdf5 ? "hdf5" : "csv"; }

std::optional<RecordingFormat> recording_format_from_string(std::string_view name) {
  for (RecordingFormat f : {RecordingFormat::kHdf5, RecordingFormat::kCsv})
    if (name == to_string(f)) return f;
  return std::nullopt;
}

// HDF5: t_s (double), 7 counts (int32), 7 SI values (double), flags (uint32); CSV: the longest
// imu.csv row. A truth value is a double, or its longest text and a comma.
std::size_t max_bytes_per_sample(RecordingFormat f) {
  return f == RecordingFormat::kHdf5 ? 8 + 7 * 4 + 7 * 8 + 4 : detail::kImuRowMax;
}
std::size_t max_bytes_per_truth_value(RecordingFormat f) {
  return f == RecordingFormat::kHdf5 ? 8 : csv::kMaxDoubleChars + 1;
}

namespace {
constexpr std::pair<SegmentKind, const char*> kSegmentKindNames[] = {
    {SegmentKind::kOrientation, "orientation"}, {SegmentKind::kRate, "rate"},
    {SegmentKind::kRotation, "rotation"},       {SegmentKind::kSetTemperature, "set_temperature"},
    {SegmentKind::kRecord, "record"},           {SegmentKind::kWait, "wait"},
    {SegmentKind::kDetected, "detected"},
};
}  // namespace

const char* to_string(SegmentKind k) {
  for (const auto& [kind, name] : kSegmentKindNames)
    if (kind == k) return name;
  return "?";
}

std::optional<SegmentKind> segment_kind_from_string(std::string_view name) {
  for (const auto& [kind, text] : kSegmentKindNames)
    if (name == text) return kind;
  return std::nullopt;
}

const std::vector<std::string>& segment_kind_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& [kind, name] : kSegmentKindNames) out.emplace_back(name);
    return out;
  }();
  return names;
}

std::ostream& operator<<(std::ostream& os, SegmentKind k) { return os << to_string(k); }

void Segment::print(std::ostream& os) const {
  os << fmt::format("#{} {}{} {:.2f}–{:.2f} s", id, to_string(kind), label.empty() ? "" : " '" + label + "'", t_start_s, t_end_s);
  if (!settled) os << " [unsettled]";
  if (!complete) os << " [incomplete]";
}

bool Segment::equals(const Segment& o, double tol) const {
  auto same = [tol](double a, double b) {
    return (std::isnan(a) && std::isnan(b)) || std::abs(a - b) <= tol * std::max(1.0, std::abs(a));
  };
  return id == o.id && step == o.step && kind == o.kind && label == o.label && repeat == o.repeat &&
         orientation == o.orientation && orientation_count == o.orientation_count && same(t_start_s, o.t_start_s) &&
         same(t_end_s, o.t_end_s) && settled == o.settled && complete == o.complete && targets == o.targets &&
         same(setpoint_c, o.setpoint_c) && same(rate, o.rate);
}

}  // namespace stend
