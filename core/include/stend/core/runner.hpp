// The runner: executes an experiment's procedure on a bench and writes the recording.
#pragma once

#include <stend/core/bench.hpp>
#include <stend/core/clock.hpp>
#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>
#include <stend/recording/recording.hpp>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace stend {

// What the runner is doing within a step (RunProgress::phase): moving a table to its target,
// dwelling once it settled, recording, settling a chamber's temperature, waiting, done. A run
// followed through its folder (the live view) knows only that it is running or how it ended
// (kRunning, kDone, kInterrupted, kFailed: run_phase_of). kNone: nothing reported yet.
enum class RunPhase { kNone, kMoving, kDwell, kRecording, kSettling, kWaiting, kDone, kRunning, kInterrupted, kFailed };
// "" | "moving" | "dwell" | "recording" | "settling" | "waiting" | "done" | "running" | "interrupted" | "failed".
const char* to_string(RunPhase p);
// The phase of that name, or nullopt.
std::optional<RunPhase> run_phase_from_string(std::string_view name);
std::ostream& operator<<(std::ostream& os, RunPhase p);
// The phase a run in this state is in, as far as its status says: running, done (complete),
// interrupted, failed.
RunPhase run_phase_of(RunStatus status);

// What the runner reports while it runs (RunOptions::on_progress): where in the procedure it is,
// the time left (stend/core/eta.hpp: the plan with the settle behaviour seen so far), and what the bench
// reads now — for the progress line and the live view.
struct RunProgress {
  int step = 0, step_count = 0;   // 1-based step being executed
  std::optional<Step::Kind> step_kind;  // of that step; none before the first
  std::string step_label;         // the step's label
  RunPhase phase = RunPhase::kNone;
  int item = 0, item_count = 0;   // orientation / rate k of K (1-based), 0 when n/a
  double run_time_s = 0.0;
  double remaining_s = 0.0;       // run time left (ProcedureEta), 0 once done
  double setpoint_c = NAN;        // chamber setpoint, NaN without a chamber or before the first
  double air_c = NAN;             // chamber air temperature, NaN without a chamber
  double die_c = NAN;
  std::uint64_t samples = 0;
  // The sensor's latest sample: specific force (m/s², sensor frame) and angular rate (rad/s).
  std::array<double, 6> latest{NAN, NAN, NAN, NAN, NAN, NAN};
  double latest_t_s = NAN;
  // The bench truth's latest row and its column names (header.truth_columns: table angles, …).
  std::vector<std::string> truth_columns;
  std::vector<double> truth;
  // Mean of the six channels over the segment being recorded (segment_samples of them; −1: none
  // open), and over the last segment closed (closed_segment: its id, −1 before the first).
  int segment = -1;
  std::uint64_t segment_samples = 0;
  std::array<double, 6> segment_mean{NAN, NAN, NAN, NAN, NAN, NAN};
  int closed_segment = -1;
  std::string closed_label;
  std::array<double, 6> closed_mean{NAN, NAN, NAN, NAN, NAN, NAN};
  double time_left_s() const { return remaining_s; }
  // The step's kind as the experiment file names it ("orientations", …), "" before the first.
  const char* step_kind_name() const { return step_kind ? stend::step_kind_name(*step_kind) : ""; }
  // Share of the run done, 0…1, from the run time so far and the time left.
  double fraction_done() const {
    const double total = run_time_s + remaining_s;
    return phase == RunPhase::kDone ? 1.0 : total > 0.0 ? run_time_s / total : 0.0;
  }
};

struct RunOptions {
  std::filesystem::path output_dir;  // empty: the experiment's outputs.directory
  std::string run_name;              // empty: "<experiment name>-<UTC yyyymmddThhmmssZ>"
  double control_period_s = 0.01;    // fixtures advanced and sensor read every period
  double truth_period_s = 0.1;       // bench-truth snapshots
  double move_timeout_s = 600.0;     // a fixture that does not settle by then fails the run
  int sensor_retries = 5;            // consecutive failed reads before the run fails
  double progress_period_s = 0.2;    // wall seconds between progress callbacks
  std::function<void(const RunProgress&)> on_progress;
  const std::atomic<bool>* stop = nullptr;  // set (e.g. by SIGINT) to stop cleanly
  std::optional<ClockKind> clock;    // overrides the experiment's clock
  // A fixture whose link fails (FixtureLinkFault) is retried every period for this long (run
  // time) before the run fails; the gap is reported in events.csv and marks segments unsettled.
  double fixture_outage_s = 30.0;
  RecordingWriterOptions store;      // how the run folder stores its data (HDF5 by default)

  // Positive periods and time-outs, at least one sensor attempt, no negative outage, a valid store.
  bool IsValid(std::string* error = nullptr) const;
};

struct RunResult {
  std::filesystem::path dir;
  RunStatus status = RunStatus::kFailed;  // kComplete, kInterrupted or kFailed
  std::string message;  // why, when not complete
  std::uint64_t samples = 0;
  int segments = 0;
  double run_time_s = 0.0;
  double wall_time_s = 0.0;
  // One line per fixture whose safe state at the end of the run was not confirmed (also an
  // "error" event in the recording); empty when every fixture confirmed it.
  std::vector<std::string> unsafe;
};

// What a run would produce, before it starts: the run time expected from the procedure (moves at
// 2 s each, temperature steps at their hold time), the sensor samples written in it and an upper
// bound of the bytes the run folder takes.
struct RunEstimate {
  double run_time_s = 0.0;
  double samples = 0.0;  // output rate × the run time with samples written
  double bytes = 0.0;    // samples and bench truth at their largest size in the chosen store
  RecordingFormat format = RecordingFormat::kHdf5;
  std::string str() const;  // "run time 1h02m40s, 3.76e+06 samples, up to 361 MB (hdf5)"
};

// The estimate for `exp` on its assembled bench, stored as `options.store` says.
RunEstimate estimate_run(const Experiment& exp, Bench& bench, const RunOptions& options);

// Throws ExperimentError (at the experiment's `limits:` block, or its file) with the numbers when
// the estimate exceeds exp.limits, or its bytes exceed the space free for this user on the file
// system that holds `output_dir` (its nearest existing ancestor, statvfs).
void check_run_limits(const Experiment& exp, const RunEstimate& estimate, const std::filesystem::path& output_dir);

// Throws std::invalid_argument unless `name` can name a run folder inside the output folder:
// not empty, not "." or "..", no '/' or '\\', no control characters, at most 255 bytes.
void check_run_name(const std::string& name);

// Where a run's records go, in the order they happen (the same calls as RecordingWriter's).
// run_experiment writes them to a run folder; a benchmark of the bench alone passes a sink that
// drops them (run_experiment_to).
class RunSink {
 public:
  virtual ~RunSink() = default;
  virtual void add_samples(const ImuSample* samples, std::size_t count) = 0;
  virtual void add_truth(double t_s, const std::vector<double>& values) = 0;  // size = truth_columns
  virtual void add_segment(const Segment& s) = 0;
  virtual void add_event(const Event& e) = 0;
  virtual void tick(double run_time_s) = 0;  // called every control period
  virtual void finish(RunStatus status, const std::string& message) = 0;
};

// Runs the experiment. Throws ExperimentError for problems found before anything runs (stage-2
// validation); once the run folder exists, faults end in a RunResult with status "failed" and
// everything recorded so far kept.
RunResult run_experiment(const Experiment& exp, const PluginHost& host, const RunOptions& options);

// The same run with its records sent to `sink` instead of a run folder (RunResult::dir empty;
// RunOptions::output_dir and run_name unused).
RunResult run_experiment_to(const Experiment& exp, const PluginHost& host, const RunOptions& options, RunSink& sink);

}  // namespace stend
