// What the live view shows, shared between whatever feeds it (a run in this process, or a run
// folder being read) and the HTTP server that serves it: one snapshot of the bench (RunProgress)
// with the recent history the charts draw, as one JSON document (docs/live-view.md, schema
// "stend.live/1").
#pragma once

#include <stend/recording/recording.hpp>
#include <stend/core/runner.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace stend::live {

// How much history the charts keep, each written once here.
struct LiveLimits {
  std::size_t channel_points = 1200;      // recent samples of the six channels (a sliding window)
  std::size_t temperature_points = 2000;  // the whole run's temperatures, thinned 2:1 when full
};

// One point of the six-channel trace: run time (s), specific force (m/s²), angular rate (rad/s).
struct ChannelPoint {
  double t_s = 0.0;
  std::array<double, 6> v{};
};

// One point of the temperature history (°C; NaN when not measured).
struct TemperaturePoint {
  double t_s = 0.0, setpoint_c = NAN, air_c = NAN, die_c = NAN;
};

// A closed segment's static mean of the six channels.
struct SegmentMean {
  int segment = -1;
  std::string label;
  std::array<double, 6> mean{};
};

class LiveState {
 public:
  explicit LiveState(std::string run_name, LiveLimits limits = {});

  // From a run in this process (RunOptions::on_progress): the snapshot, and its latest sample,
  // temperatures and closed segment appended to the history.
  void update(const RunProgress& p);
  // The run's status (running until the run ends) and why it ended.
  void set_status(RunStatus status, const std::string& message = "");

  // From a run folder (stend watch): the whole picture replaced at once.
  void replace(const RunProgress& p, std::vector<ChannelPoint> channels, std::vector<TemperaturePoint> temperatures,
               std::vector<SegmentMean> means, RunStatus status, const std::string& message);

  // The document GET /api/state returns.
  nlohmann::json to_json() const;
  // How many times it changed (the page shows it; tests wait on it).
  std::uint64_t version() const;

 private:
  void add_temperature(const TemperaturePoint& p);

  mutable std::mutex mutex_;
  std::string run_name_;
  LiveLimits limits_;
  RunProgress progress_;
  RunStatus status_ = RunStatus::kRunning;
  std::string message_;
  std::deque<ChannelPoint> channels_;
  std::vector<TemperaturePoint> temperatures_;
  std::size_t temperature_stride_ = 1, temperature_skipped_ = 0;  // thinning of a long history
  std::vector<SegmentMean> means_;
  std::uint64_t version_ = 0;
};

// The fixture angles of a truth row: "<fixture>.<axis>.meas_deg" columns as {"table.tilt": deg, …}.
nlohmann::json table_angles_deg(const std::vector<std::string>& columns, const std::vector<double>& row);

}  // namespace stend::live
