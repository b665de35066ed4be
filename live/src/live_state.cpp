#include "stend/live/live_state.hpp"

#include <cmath>
#include <utility>

namespace stend::live {

namespace {

const char* const kChannels[6] = {"ax_mps2", "ay_mps2", "az_mps2", "gx_radps", "gy_radps", "gz_radps"};

// JSON has no NaN: null instead.
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json six(const std::array<double, 6>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

nlohmann::json table_angles_deg(const std::vector<std::string>& columns, const std::vector<double>& row) {
  nlohmann::json out = nlohmann::json::object();
  const std::string tail = ".meas_deg";
  for (std::size_t i = 0; i < columns.size() && i < row.size(); ++i)
    if (ends_with(columns[i], tail)) out[columns[i].substr(0, columns[i].size() - tail.size())] = number(row[i]);
  return out;
}

LiveState::LiveState(std::string run_name, LiveLimits limits) : run_name_(std::move(run_name)), limits_(limits) {}

void LiveState::update(const RunProgress& p) {
  const std::lock_guard lock(mutex_);
  const int closed_before = progress_.closed_segment;
  progress_ = p;
  if (std::isfinite(p.latest_t_s) && (channels_.empty() || p.latest_t_s > channels_.back().t_s)) {
    channels_.push_back({p.latest_t_s, p.latest});
    while (channels_.size() > limits_.channel_points) channels_.pop_front();
  }
  if (std::isfinite(p.air_c)) add_temperature({p.run_time_s, p.setpoint_c, p.air_c, p.die_c});
  if (p.closed_segment >= 0 && p.closed_segment != closed_before)
    means_.push_back({p.closed_segment, p.closed_label, p.closed_mean});
  ++version_;
}

// Keeps the whole run in at most temperature_points: when full, every other point is dropped and
// from then on only every stride-th update is kept.
void LiveState::add_temperature(const TemperaturePoint& p) {
  if (++temperature_skipped_ < temperature_stride_) return;
  temperature_skipped_ = 0;
  temperatures_.push_back(p);
  if (temperatures_.size() < limits_.temperature_points) return;
  std::vector<TemperaturePoint> half;
  for (std::size_t i = 0; i < temperatures_.size(); i += 2) half.push_back(temperatures_[i]);
  temperatures_ = std::move(half);
  temperature_stride_ *= 2;
}

void LiveState::set_status(RunStatus status, const std::string& message) {
  const std::lock_guard lock(mutex_);
  status_ = status;
  message_ = message;
  ++version_;
}

void LiveState::replace(const RunProgress& p, std::vector<ChannelPoint> channels,
                        std::vector<TemperaturePoint> temperatures, std::vector<SegmentMean> means, RunStatus status,
                        const std::string& message) {
  const std::lock_guard lock(mutex_);
  progress_ = p;
  channels_.assign(channels.begin(), channels.end());
  temperatures_ = std::move(temperatures);
  means_ = std::move(means);
  status_ = status;
  message_ = message;
  ++version_;
}

std::uint64_t LiveState::version() const {
  const std::lock_guard lock(mutex_);
  return version_;
}

nlohmann::json LiveState::to_json() const {
  const std::lock_guard lock(mutex_);
  const RunProgress& p = progress_;
  nlohmann::json j;
  j["schema"] = "stend.live/1";
  j["run"] = run_name_;
  j["version"] = version_;
  j["status"] = to_string(status_);
  j["message"] = message_;
  j["step"] = p.step;
  j["step_count"] = p.step_count;
  j["step_kind"] = p.step_kind_name();
  j["step_label"] = p.step_label;
  j["phase"] = to_string(p.phase);
  j["item"] = p.item;
  j["item_count"] = p.item_count;
  j["run_time_s"] = p.run_time_s;
  const bool ended = status_ != RunStatus::kRunning;
  j["remaining_s"] = ended ? 0.0 : p.remaining_s;
  j["fraction_done"] = status_ == RunStatus::kComplete ? 1.0 : p.fraction_done();
  j["samples"] = p.samples;
  j["setpoint_c"] = number(p.setpoint_c);
  j["air_c"] = number(p.air_c);
  j["die_c"] = number(p.die_c);
  j["table_deg"] = table_angles_deg(p.truth_columns, p.truth);
  j["channels"] = nlohmann::json::array();
  for (const char* c : kChannels) j["channels"].push_back(c);
  j["latest"] = six(p.latest);
  j["segment"] = {{"id", p.segment}, {"samples", p.segment_samples}, {"mean", six(p.segment_mean)}};
  nlohmann::json means = nlohmann::json::array();
  for (const SegmentMean& m : means_) means.push_back({{"segment", m.segment}, {"label", m.label}, {"mean", six(m.mean)}});
  j["means"] = std::move(means);
  nlohmann::json trace = {{"t_s", nlohmann::json::array()}};
  for (const char* c : kChannels) trace[c] = nlohmann::json::array();
  for (const ChannelPoint& cp : channels_) {
    trace["t_s"].push_back(cp.t_s);
    for (std::size_t c = 0; c < 6; ++c) trace[kChannels[c]].push_back(number(cp.v[c]));
  }
  j["trace"] = std::move(trace);
  nlohmann::json temps = {{"t_s", nlohmann::json::array()}, {"setpoint_c", nlohmann::json::array()},
                          {"air_c", nlohmann::json::array()}, {"die_c", nlohmann::json::array()}};
  for (const TemperaturePoint& tp : temperatures_) {
    temps["t_s"].push_back(tp.t_s);
    temps["setpoint_c"].push_back(number(tp.setpoint_c));
    temps["air_c"].push_back(number(tp.air_c));
    temps["die_c"].push_back(number(tp.die_c));
  }
  j["temperatures"] = std::move(temps);
  return j;
}

}  // namespace stend::live
