#include "stend/live/run_folder_feed.hpp"

#include "stend/core/eta.hpp"
#include "stend/recording/recording.hpp"
#include "stend/recording/samples.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace stend::live {

namespace {

constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

std::array<double, 6> channels_of(const ImuSample& s) {
  return {s.accel_mps2[0], s.accel_mps2[1], s.accel_mps2[2], s.gyro_radps[0], s.gyro_radps[1], s.gyro_radps[2]};
}

int column(const Recording& rec, const std::string& name) { return rec.truth_column(name); }

// The chamber's setpoint column: "<chamber>.temperature.cmd_degC"; −1 when there is none.
int setpoint_column(const Recording& rec) {
  const auto& cols = rec.header.truth_columns;
  for (std::size_t i = 0; i < cols.size(); ++i)
    if (cols[i].find(".temperature.cmd_") != std::string::npos) return static_cast<int>(i);
  return -1;
}

double at(const std::vector<double>& row, int c) {
  return c >= 0 && static_cast<std::size_t>(c) < row.size() ? row[static_cast<std::size_t>(c)] : kUnknown;
}

// Evenly spaced indices of [0, n) keeping at most `max_points` (the last always kept).
std::vector<std::size_t> thinned(std::size_t n, std::size_t max_points) {
  std::vector<std::size_t> idx;
  if (n == 0 || max_points == 0) return idx;
  const std::size_t stride = (n + max_points - 1) / max_points;
  for (std::size_t i = (n - 1) % stride; i < n; i += stride) idx.push_back(i);
  return idx;
}

// The six channels' mean over one segment's samples, read a chunk at a time.
SegmentMean mean_of(const SampleSource& src, const Segment& s) {
  SegmentMean m{s.id, s.targets.empty() ? s.label : s.targets, {}};
  const IndexRange r = index_range(src, s.t_start_s, s.t_end_s);
  std::array<double, 6> sum{};
  for_each_chunk(src, r.first, r.last, [&](const ImuSample* chunk, std::size_t n, std::uint64_t) {
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = channels_of(chunk[i]);
      for (std::size_t c = 0; c < 6; ++c) sum[c] += v[c];
    }
  });
  for (std::size_t c = 0; c < 6; ++c) m.mean[c] = r.size() ? sum[c] / static_cast<double>(r.size()) : kUnknown;
  return m;
}

bool is_item_step(const Step& s) { return s.kind == Step::Kind::kOrientations || s.kind == Step::Kind::kRates; }
int item_count(const Step& s) {
  return static_cast<int>(s.kind == Step::Kind::kRates ? s.rates.size() : s.orientations.size());
}

}  // namespace

RunFolderFeed::RunFolderFeed(std::filesystem::path run_dir, std::vector<Step> procedure, LiveLimits limits)
    : dir_(std::move(run_dir)), procedure_(std::move(procedure)), limits_(limits) {}

RunStatus RunFolderFeed::refresh(LiveState& state) {
  const Recording rec = Recording::open(dir_, SampleLoading::kStream, TruthLoading::kLoad);
  const SampleSource& src = rec.sample_source();
  RunProgress p;
  p.step_count = static_cast<int>(procedure_.size());
  p.truth_columns = rec.header.truth_columns;
  p.samples = src.size();

  // The last samples, thinned to the chart's window.
  std::vector<ChannelPoint> channels;
  const std::uint64_t n = src.size();
  const std::uint64_t first = n > 2 * limits_.channel_points ? n - 2 * limits_.channel_points : 0;
  const std::vector<ImuSample> tail = read_interval(src, n ? sample_at(src, first).t_s : 0.0, INFINITY);
  for (std::size_t i : thinned(tail.size(), limits_.channel_points)) channels.push_back({tail[i].t_s, channels_of(tail[i])});
  if (!tail.empty()) {
    p.latest = channels_of(tail.back());
    p.latest_t_s = tail.back().t_s;
  }

  // Temperatures over the whole run, thinned; the latest truth row.
  const int air = column(rec, "air_c"), die = column(rec, "die_c"), setpoint = setpoint_column(rec);
  std::vector<TemperaturePoint> temperatures;
  if (air >= 0)
    for (std::size_t i : thinned(rec.truth.size(), limits_.temperature_points)) {
      const auto& row = rec.truth[i];
      if (std::isfinite(at(row, air))) temperatures.push_back({rec.truth_t[i], at(row, setpoint), at(row, air), at(row, die)});
    }
  if (!rec.truth.empty()) {
    p.truth = rec.truth.back();
    p.air_c = at(p.truth, air);
    p.die_c = at(p.truth, die);
    p.setpoint_c = at(p.truth, setpoint);
  }
  p.run_time_s = std::max(rec.truth_t.empty() ? 0.0 : rec.truth_t.back(), std::isfinite(p.latest_t_s) ? p.latest_t_s : 0.0);

  // Closed segments' means (each computed once).
  std::vector<SegmentMean> means;
  for (const Segment& s : rec.segments) {
    if (!means_.count(s.id)) means_[s.id] = mean_of(src, s);
    means.push_back(means_[s.id]);
  }
  if (!rec.segments.empty()) {
    p.closed_segment = rec.segments.back().id;
    p.closed_label = means.back().label;
    p.closed_mean = means.back().mean;
  }

  // Where in the procedure, and the time left: the segments replayed through ProcedureEta.
  ProcedureEta eta(procedure_);
  int current = procedure_.empty() ? -1 : 0;
  double step_t0 = 0.0;
  int items_done = 0;  // of the current step
  eta.step_started(0, 0.0, temperatures.empty() ? kUnknown : temperatures.front().air_c);
  for (const Segment& s : rec.segments) {
    if (s.step < 0 || static_cast<std::size_t>(s.step) >= procedure_.size()) continue;
    const Step& st = procedure_[static_cast<std::size_t>(s.step)];
    if (s.step != current) {
      eta.step_finished(s.t_start_s);
      current = s.step;
      step_t0 = s.kind == SegmentKind::kSetTemperature ? s.t_start_s : s.t_start_s - st.dwell_s - eta.move_s();
      eta.step_started(static_cast<std::size_t>(s.step), step_t0, NAN);
      items_done = 0;
    }
    if (is_item_step(st)) {
      ++items_done;
      eta.item_started(s.t_start_s - st.dwell_s - eta.move_s());
      eta.move_finished(s.t_start_s - st.dwell_s);
    }
    const bool last_item = !is_item_step(st) || s.orientation + 1 >= item_count(st);
    if (last_item && static_cast<std::size_t>(s.step) + 1 < procedure_.size()) {
      if (st.kind == Step::Kind::kSetTemperature) eta.band_entered(s.t_end_s - st.hold_s);
      eta.step_finished(s.t_end_s);
      current = s.step + 1;
      items_done = 0;
      eta.step_started(static_cast<std::size_t>(current), s.t_end_s, p.air_c);
    }
  }
  if (current >= 0) {
    const Step& st = procedure_[static_cast<std::size_t>(current)];
    p.step = current + 1;
    p.step_kind = st.kind;
    p.step_label = st.label;
    p.item_count = is_item_step(st) ? item_count(st) : 0;
    p.item = rec.header.status == RunStatus::kRunning ? std::min(items_done + 1, p.item_count) : items_done;
    // A set_temperature step in progress: in the band since the truth's last entry into it.
    if (st.kind == Step::Kind::kSetTemperature && air >= 0) {
      double since = NAN;
      for (std::size_t i = rec.truth.size(); i-- > 0 && std::abs(at(rec.truth[i], air) - st.setpoint_c) <= st.tolerance_c;)
        since = rec.truth_t[i];
      if (std::isfinite(since)) eta.band_entered(since);
    }
  }
  const RunStatus status = rec.header.status;
  p.phase = run_phase_of(status);
  if (status != RunStatus::kRunning) eta.finished();
  p.remaining_s = procedure_.empty() ? kUnknown : eta.remaining_s(p.run_time_s, p.air_c);
  // A damaged run (truncated, rows missing against run.json) says so beside its status.
  const std::string message =
      rec.damage.empty() ? std::string()
                         : fmt::format("damaged: {} of {} samples are readable: {}", rec.sample_count(), rec.written_samples, rec.damage);
  state.replace(p, std::move(channels), std::move(temperatures), std::move(means), status, message);
  return status;
}

}  // namespace stend::live
