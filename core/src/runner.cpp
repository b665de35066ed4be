#include "stend/core/runner.hpp"

#include "stend/core/eta.hpp"
#include "stend/recording/recording.hpp"
#include "stend/recording/version.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace stend {

namespace {

std::string utc_stamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

int axis_index(const Fixture& f, const std::string& name) {
  const auto axes = f.axes();
  for (std::size_t i = 0; i < axes.size(); ++i)
    if (axes[i].name == name) return static_cast<int>(i);
  throw std::logic_error("fixture has no axis '" + name + "'");  // stage 2 checked every step's axes
}

class Stopped : public std::exception {
 public:
  const char* what() const noexcept override { return "stopped by request"; }
};

// One run: owns the loop state so the procedure reads as a list of steps.
class Run {
 public:
  Run(const Experiment& exp, Bench& bench, Clock& clock, RunSink& writer, const RunOptions& opt)
      : exp_(exp), bench_(bench), clock_(clock), writer_(writer), opt_(opt), eta_(exp.procedure) {
    progress_.step_count = static_cast<int>(exp.procedure.size());
    progress_.truth_columns = bench.truth_columns();
    wall_start_ = std::chrono::steady_clock::now();
    last_progress_ = wall_start_ - std::chrono::hours(1);
  }

  void execute() {
    bench_.sensor().start(0.0);
    advance_fixtures(0.0);
    snapshot(0.0);
    for (std::size_t i = 0; i < exp_.procedure.size(); ++i) {
      const Step& s = exp_.procedure[i];
      progress_.step = static_cast<int>(i) + 1;
      progress_.step_kind = s.kind;
      progress_.step_label = s.label;
      progress_.item = progress_.item_count = 0;
      eta_.step_started(i, clock_.now_s(), chamber_c());
      run_step(static_cast<int>(i), s);
      eta_.step_finished(clock_.now_s());
    }
    eta_.finished();
    progress_.phase = RunPhase::kDone;
    report(true);
  }

  // Closes the open segment (if any) as incomplete, e.g. after a stop or a fault.
  void abandon() {
    if (open_) {
      segment_.t_end_s = clock_.now_s();
      segment_.complete = false;
      writer_.add_segment(segment_);
      ++segments_;
      open_ = false;
    }
  }

  std::uint64_t samples() const { return samples_; }
  int segments() const { return segments_; }

 private:
  void run_step(int index, const Step& s) {
    switch (s.kind) {
      case Step::Kind::kSetTemperature: set_temperature(index, s); break;
      case Step::Kind::kOrientations: orientations(index, s); break;
      case Step::Kind::kRates: rates(index, s); break;
      case Step::Kind::kRecord:
        begin_segment(index, s, SegmentKind::kRecord, -1, 0, "");
        progress_.phase = RunPhase::kRecording;
        advance_for(s.record_s);
        end_segment();
        break;
      case Step::Kind::kWait:
        progress_.phase = RunPhase::kWaiting;
        advance_for(s.dwell_s);
        break;
      case Step::Kind::kSetVibration: {
        Fixture& f = fixture(s.fixture);
        f.command(static_cast<std::size_t>(axis_index(f, "frequency")), CommandMode::kSetpoint, s.frequency_hz);
        f.command(static_cast<std::size_t>(axis_index(f, "amplitude")), CommandMode::kSetpoint, s.amplitude_g);
        writer_.add_event({clock_.now_s(), "info", s.fixture,
                           fmt::format("vibration {} g at {} Hz", s.amplitude_g, s.frequency_hz)});
        break;
      }
      case Step::Kind::kFaces:  // observed steps: refused before the run (require_runnable)
      case Step::Kind::kTurns:
      case Step::Kind::kRateLegs:
      case Step::Kind::kStill:
        throw std::logic_error(std::string("runner: an observed step (") + step_kind_name(s.kind) + ") cannot run");
    }
  }

  void set_temperature(int index, const Step& s) {
    Fixture& chamber = fixture(s.fixture);
    chamber.command(0, CommandMode::kSetpoint, s.setpoint_c);
    setpoint_c_ = s.setpoint_c;
    tolerance_c_ = s.tolerance_c;
    progress_.setpoint_c = s.setpoint_c;
    progress_.phase = RunPhase::kSettling;
    if (s.record_settling) begin_segment(index, s, SegmentKind::kSetTemperature, -1, 0, fmt::format("{}.temperature={} degC", s.fixture, s.setpoint_c));
    const double t0 = clock_.now_s();
    if (!s.record_settling) writing_ = false;
    double in_band_since = -1.0;  // run time the measurement entered the band, −1 when outside
    while (true) {
      const double t = clock_.now_s();
      const bool in_band = std::abs(chamber.measured(0) - s.setpoint_c) <= s.tolerance_c;
      if (!in_band && in_band_since >= 0.0) eta_.band_left();
      if (in_band && in_band_since < 0.0) eta_.band_entered(t);
      if (!in_band) in_band_since = -1.0;
      else if (in_band_since < 0.0) in_band_since = t;
      if (in_band_since >= 0.0 && t - in_band_since >= s.hold_s) break;
      if (t - t0 >= s.timeout_s) {
        writer_.add_event({t, "warning", s.fixture,
                           fmt::format("temperature did not settle at {} degC within {} s (measured {:.2f} degC); continuing, "
                                       "segments are marked unsettled",
                                       s.setpoint_c, s.timeout_s, chamber.measured(0))});
        if (open_) segment_.settled = false;
        break;
      }
      advance_for(opt_.control_period_s);
    }
    if (open_) end_segment();
    if (!s.record_settling) resume_writing(t0, s.fixture);
  }

  // After a stretch without samples written (record: false): the next sample written carries
  // kGapBefore and an event says which stretch was left out.
  void resume_writing(double since_s, const std::string& source) {
    writing_ = true;
    gap_ = true;
    writer_.add_event({clock_.now_s(), "info", source,
                       fmt::format("sensor samples from {:.3f} s to {:.3f} s not recorded (record: false)", since_s,
                                   clock_.now_s())});
  }

  void orientations(int index, const Step& s) {
    Fixture& table = fixture(s.fixture);
    progress_.item_count = static_cast<int>(s.orientations.size());
    for (std::size_t k = 0; k < s.orientations.size(); ++k) {
      progress_.item = static_cast<int>(k) + 1;
      std::string targets;
      for (const AxisTarget& a : s.orientations[k].targets) {
        table.command(static_cast<std::size_t>(axis_index(table, a.axis)), CommandMode::kPosition, a.value);
        targets += fmt::format("{}{}.{}={} deg", targets.empty() ? "" : "; ", s.fixture, a.axis, a.value);
      }
      move_and_record(index, s, table, SegmentKind::kOrientation, static_cast<int>(k), targets, NAN);
    }
  }

  void rates(int index, const Step& s) {
    Fixture& table = fixture(s.fixture);
    const auto axis = static_cast<std::size_t>(axis_index(table, s.axis));
    progress_.item_count = static_cast<int>(s.rates.size());
    for (std::size_t k = 0; k < s.rates.size(); ++k) {
      progress_.item = static_cast<int>(k) + 1;
      table.command(axis, CommandMode::kRate, s.rates[k]);
      move_and_record(index, s, table, SegmentKind::kRate, static_cast<int>(k),
                      fmt::format("{}.{} rate={} deg/s", s.fixture, s.axis, s.rates[k]), s.rates[k]);
    }
    table.command(axis, CommandMode::kRate, 0.0);
    progress_.phase = RunPhase::kMoving;
    wait_settled(table, s.fixture);
  }

  void move_and_record(int index, const Step& s, Fixture& table, SegmentKind kind, int k,
                       const std::string& targets, double rate) {
    progress_.phase = RunPhase::kMoving;
    eta_.item_started(clock_.now_s());
    wait_settled(table, s.fixture);
    eta_.move_finished(clock_.now_s());
    progress_.phase = RunPhase::kDwell;
    advance_for(s.dwell_s);
    begin_segment(index, s, kind, k, static_cast<int>(s.orientations.empty() ? s.rates.size() : s.orientations.size()), targets);
    segment_.rate = rate;
    progress_.phase = RunPhase::kRecording;
    const double t_end = clock_.now_s() + s.record_s;
    while (clock_.now_s() < t_end - 1e-9) {
      advance_to(std::min(t_end, clock_.now_s() + opt_.control_period_s));
      if (!table.settled()) segment_.settled = false;
    }
    end_segment();
  }

  void wait_settled(Fixture& f, const std::string& id) {
    const double t0 = clock_.now_s();
    advance_for(opt_.control_period_s);  // let the command take effect
    while (!f.settled()) {
      if (clock_.now_s() - t0 > opt_.move_timeout_s)
        throw IoError(fmt::format("fixture '{}' did not settle within {} s", id, opt_.move_timeout_s));
      advance_for(opt_.control_period_s);
    }
  }

  void begin_segment(int index, const Step& s, SegmentKind kind, int k, int count, const std::string& targets) {
    segment_ = Segment{};
    segment_.id = segments_;
    segment_.step = index;
    segment_.kind = kind;
    segment_.label = s.label;
    segment_.repeat = s.repeat_index;
    segment_.orientation = k;
    segment_.orientation_count = count;
    segment_.t_start_s = clock_.now_s();
    segment_.targets = targets;
    segment_.setpoint_c = setpoint_c_;
    open_ = true;
    segment_sum_.fill(0.0);
    segment_n_ = 0;
  }

  void end_segment() {
    segment_.t_end_s = clock_.now_s();
    progress_.closed_segment = segment_.id;
    progress_.closed_label = segment_.targets.empty() ? segment_.label : segment_.targets;
    progress_.closed_mean = segment_mean();
    writer_.add_segment(segment_);
    ++segments_;
    open_ = false;
    snapshot(segment_.t_end_s);
  }

  void advance_for(double duration_s) {
    const double t_end = clock_.now_s() + duration_s;
    while (clock_.now_s() < t_end - 1e-9) advance_to(std::min(t_end, clock_.now_s() + opt_.control_period_s));
  }

  // The one place time moves: fixtures, sensor, truth snapshots, durability, progress, stop.
  void advance_to(double t) {
    if (opt_.stop && opt_.stop->load()) throw Stopped();
    clock_.wait_until(t);
    advance_fixtures(t);
    read_sensor(t);
    for (std::size_t i = 0; i < bench_.fixture_count(); ++i) bench_.fixture(i).observe(buffer_.data(), buffer_.size());
    if (t >= next_truth_ - 1e-12) {
      snapshot(t);
      next_truth_ = t + opt_.truth_period_s;
    }
    if (open_ && bench_.chamber_index() >= 0 && std::isfinite(setpoint_c_) && segment_.kind != SegmentKind::kSetTemperature) {
      const double m = bench_.fixture(static_cast<std::size_t>(bench_.chamber_index())).measured(0);
      if (std::abs(m - setpoint_c_) > tolerance_c_) segment_.settled = false;
    }
    writer_.tick(t);
    report(false);
  }

  // Every fixture advanced to t. A link fault (FixtureLinkFault) is ridden out: reported once
  // when it starts (and when its text changes), the open segment marked unsettled (the truth
  // repeats the last known state), reported again when the link is back, and fatal only after
  // RunOptions::fixture_outage_s. Any other exception ends the run.
  void advance_fixtures(double t) {
    outage_since_.resize(bench_.fixture_count(), -1.0);
    outage_text_.resize(bench_.fixture_count());
    for (std::size_t i = 0; i < bench_.fixture_count(); ++i) {
      const std::string& id = bench_.fixture_id(i);
      try {
        bench_.fixture(i).advance(t);
        if (outage_since_[i] >= 0.0) {
          writer_.add_event({t, "warning", id,
                             fmt::format("link back after {:.3f} s; bench truth from {:.3f} s to {:.3f} s repeats the "
                                         "last known state (gap)",
                                         t - outage_since_[i], outage_since_[i], t)});
          outage_since_[i] = -1.0;
          outage_text_[i].clear();
        }
      } catch (const FixtureLinkFault& e) {
        if (outage_since_[i] < 0.0) outage_since_[i] = t;
        if (outage_text_[i] != e.what()) {
          writer_.add_event({t, "error", id, fmt::format("link fault, retrying: {}", e.what())});
          outage_text_[i] = e.what();
        }
        if (open_) segment_.settled = false;
        if (t - outage_since_[i] > opt_.fixture_outage_s)
          throw IoError(fmt::format("fixture '{}' unreachable for {:.1f} s: {}", id, t - outage_since_[i], e.what()));
      }
    }
  }

  void read_sensor(double t) {
    buffer_.clear();
    try {
      bench_.sensor().acquire(t, bench_, buffer_);
      failures_ = 0;
    } catch (const std::exception& e) {
      // Keep what arrived, report the fault, mark the gap, retry on the next period.
      ++failures_;
      writer_.add_event({t, "error", "sensor", fmt::format("read failed (attempt {} of {}): {}", failures_,
                                                            opt_.sensor_retries, e.what())});
      gap_ = true;
      if (failures_ >= opt_.sensor_retries)
        throw IoError(fmt::format("sensor failed {} times in a row: {}", failures_, e.what()));
    }
    if (!buffer_.empty() && writing_) {
      if (gap_) {
        buffer_.front().flags |= kGapBefore;
        gap_ = false;
      }
      writer_.add_samples(buffer_.data(), buffer_.size());
      samples_ += buffer_.size();
      if (open_) add_to_segment_mean();
    }
  }

  void add_to_segment_mean() {
    for (const ImuSample& x : buffer_) {
      for (int c = 0; c < 3; ++c) {
        segment_sum_[static_cast<std::size_t>(c)] += x.accel_mps2[c];
        segment_sum_[static_cast<std::size_t>(c) + 3] += x.gyro_radps[c];
      }
    }
    segment_n_ += buffer_.size();
  }

  std::array<double, 6> segment_mean() const {
    std::array<double, 6> m{NAN, NAN, NAN, NAN, NAN, NAN};
    if (segment_n_ > 0)
      for (std::size_t c = 0; c < 6; ++c) m[c] = segment_sum_[c] / static_cast<double>(segment_n_);
    return m;
  }

  double chamber_c() {
    if (bench_.chamber_index() < 0) return NAN;
    return bench_.fixture(static_cast<std::size_t>(bench_.chamber_index())).measured(0);
  }

  void snapshot(double t) {
    bench_.truth_row(t, row_);
    writer_.add_truth(t, row_);
  }

  Fixture& fixture(const std::string& id) {
    const int i = bench_.fixture_index(id);
    if (i < 0) throw std::logic_error("no fixture '" + id + "'");  // stage 2 checked every step's fixture
    return bench_.fixture(static_cast<std::size_t>(i));
  }

  void report(bool force) {
    if (!opt_.on_progress) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && std::chrono::duration<double>(now - last_progress_).count() < opt_.progress_period_s) return;
    last_progress_ = now;
    progress_.run_time_s = clock_.now_s();
    progress_.remaining_s = eta_.remaining_s(progress_.run_time_s, chamber_c());
    progress_.samples = samples_;
    if (!buffer_.empty()) {
      const ImuSample& x = buffer_.back();
      for (int c = 0; c < 3; ++c) {
        progress_.latest[static_cast<std::size_t>(c)] = x.accel_mps2[c];
        progress_.latest[static_cast<std::size_t>(c) + 3] = x.gyro_radps[c];
      }
      progress_.latest_t_s = x.t_s;
    }
    progress_.truth = row_;
    progress_.segment = open_ ? segment_.id : -1;
    progress_.segment_samples = open_ ? segment_n_ : 0;
    progress_.segment_mean = segment_mean();
    if (bench_.chamber_index() >= 0) {
      double air = NAN, die = NAN;
      bench_.fixture(static_cast<std::size_t>(bench_.chamber_index())).thermal(progress_.run_time_s, air, die);
      progress_.air_c = air;
      progress_.die_c = die;
    }
    opt_.on_progress(progress_);
  }

  const Experiment& exp_;
  Bench& bench_;
  Clock& clock_;
  RunSink& writer_;
  const RunOptions& opt_;
  RunProgress progress_;
  ProcedureEta eta_;
  std::array<double, 6> segment_sum_{};  // the open segment's channel sums (segment_mean)
  std::uint64_t segment_n_ = 0;
  std::chrono::steady_clock::time_point wall_start_, last_progress_;
  std::vector<ImuSample> buffer_;
  std::vector<double> outage_since_;       // per fixture: run time its link failed, −1 when up
  std::vector<std::string> outage_text_;   // per fixture: the fault text last reported
  std::vector<double> row_;
  Segment segment_;
  bool open_ = false;
  bool gap_ = false;
  bool writing_ = true;  // sensor samples go to the sink (false while settling with record: false)
  int failures_ = 0;
  int segments_ = 0;
  std::uint64_t samples_ = 0;
  double next_truth_ = 0.0;
  double setpoint_c_ = NAN;
  double tolerance_c_ = INFINITY;
};

// The run folder as a RunSink.
class RecordingSink final : public RunSink {
 public:
  explicit RecordingSink(RecordingWriter& w) : w_(w) {}
  void add_samples(const ImuSample* samples, std::size_t count) override { w_.add_samples(samples, count); }
  void add_truth(double t_s, const std::vector<double>& values) override { w_.add_truth(t_s, values); }
  void add_segment(const Segment& s) override { w_.add_segment(s); }
  void add_event(const Event& e) override { w_.add_event(e); }
  void tick(double run_time_s) override { w_.tick(run_time_s); }
  void finish(RunStatus status, const std::string& message) override { w_.finish(status, message); }

 private:
  RecordingWriter& w_;
};

// The clock the run uses: the options', else the experiment's; auto resolved against the bench.
ClockKind clock_kind(const Experiment& exp, const Bench& bench, const RunOptions& options) {
  const ClockKind kind = options.clock.value_or(exp.clock);
  if (kind == ClockKind::kAuto) return bench.simulated() ? ClockKind::kSimulated : ClockKind::kWall;
  return kind;
}

// "crc32:<8 hex digits>" (zlib's CRC-32, as `python3 -c 'import zlib…'` or `crc32 FILE` print it)
// of a file's content: provenance of a plugin library, not a security check; "" when the file
// cannot be read.
std::string file_hash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  uLong crc = crc32(0L, Z_NULL, 0);
  std::vector<char> buf(1 << 16);
  while (in.read(buf.data(), static_cast<std::streamsize>(buf.size())) || in.gcount() > 0)
    crc = crc32(crc, reinterpret_cast<const Bytef*>(buf.data()), static_cast<uInt>(in.gcount()));
  return fmt::format("crc32:{:08x}", crc);
}

RecordingHeader run_header(const Experiment& exp, const PluginHost& host, Bench& bench, ClockKind clock) {
  RecordingHeader header;
  header.experiment_name = exp.name;
  header.experiment_file = exp.file;
  header.stend_version = version();
  auto use = [&](const std::string& role, const std::string& name) {
    const PluginRecord* r = host.record_of(name);
    header.plugins.push_back({role, name, r && r->info ? r->info->version : "", r ? r->file : "", r ? r->origin : "",
                              r ? file_hash(r->file) : ""});
  };
  use("sensor", exp.sensor.plugin);
  for (const FixtureDecl& f : exp.fixtures) use(f.id, f.plugin);
  header.identity = bench.sensor().identity();
  header.info = bench.sensor().info();
  header.gravity_mps2 = exp.gravity.resolved_mps2;
  header.latitude_deg = exp.gravity.latitude_deg;
  header.height_m = exp.gravity.height_m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) header.mounting_R.push_back(exp.R_sensor_from_mount(r, c));
  header.seed = exp.seed;
  header.clock = to_string(clock);
  header.truth_columns = bench.truth_columns();
  return header;
}

// Runs the procedure on an assembled bench into `sink`; faults end in the result's status.
RunResult execute(const Experiment& exp, Bench& bench, Clock& clock, RunSink& sink, const RunOptions& options) {
  RunResult result;
  const auto wall0 = std::chrono::steady_clock::now();
  Run run(exp, bench, clock, sink, options);
  try {
    run.execute();
    result.status = RunStatus::kComplete;
  } catch (const Stopped&) {
    result.status = RunStatus::kInterrupted;
    result.message = "stopped by request; everything recorded so far is kept";
  } catch (const std::exception& e) {
    result.status = RunStatus::kFailed;
    result.message = e.what();
    sink.add_event({clock.now_s(), "error", "runner", e.what()});
  }
  if (result.status != RunStatus::kComplete) run.abandon();
  result.unsafe = bench.safe_state();
  for (const std::string& why : result.unsafe)
    sink.add_event({clock.now_s(), "error", "runner", "safe state NOT confirmed: " + why});
  if (result.status != RunStatus::kComplete)
    sink.add_event({clock.now_s(), "warning", "runner",
                    std::string("run ") + to_string(result.status) +
                        (result.unsafe.empty() ? "; fixtures put in their safe state (confirmed)"
                                               : "; check the fixtures listed above by hand: their safe state is not confirmed")});
  try {
    bench.sensor().stop();
  } catch (const std::exception& e) {
    sink.add_event({clock.now_s(), "warning", "sensor", std::string("stop failed: ") + e.what()});
  }
  sink.finish(result.status, result.message);
  result.samples = run.samples();
  result.segments = run.segments();
  result.run_time_s = clock.now_s();
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return result;
}

constexpr std::pair<RunPhase, const char*> kRunPhaseNames[] = {
    {RunPhase::kNone, ""},           {RunPhase::kMoving, "moving"},   {RunPhase::kDwell, "dwell"},
    {RunPhase::kRecording, "recording"}, {RunPhase::kSettling, "settling"}, {RunPhase::kWaiting, "waiting"},
    {RunPhase::kDone, "done"},       {RunPhase::kRunning, "running"}, {RunPhase::kInterrupted, "interrupted"},
    {RunPhase::kFailed, "failed"},
};
}  // namespace

const char* to_string(RunPhase p) {
  for (const auto& [phase, name] : kRunPhaseNames)
    if (phase == p) return name;
  return "?";
}

std::optional<RunPhase> run_phase_from_string(std::string_view name) {
  for (const auto& [phase, text] : kRunPhaseNames)
    if (name == text) return phase;
  return std::nullopt;
}

std::ostream& operator<<(std::ostream& os, RunPhase p) { return os << to_string(p); }

RunPhase run_phase_of(RunStatus status) {
  switch (status) {
    case RunStatus::kRunning: return RunPhase::kRunning;
    case RunStatus::kComplete: return RunPhase::kDone;
    case RunStatus::kInterrupted: return RunPhase::kInterrupted;
    case RunStatus::kFailed: return RunPhase::kFailed;
  }
  return RunPhase::kNone;
}

bool RunOptions::IsValid(std::string* error) const {
  if (!(control_period_s > 0.0 && truth_period_s > 0.0 && move_timeout_s > 0.0))
    return invalid(error, "control_period_s, truth_period_s and move_timeout_s must be > 0");
  if (!(sensor_retries >= 1)) return invalid(error, "sensor_retries must be >= 1");
  if (!(progress_period_s >= 0.0 && fixture_outage_s >= 0.0))
    return invalid(error, "progress_period_s and fixture_outage_s must be >= 0");
  return store.IsValid(error);
}

RunResult run_experiment(const Experiment& exp, const PluginHost& host, const RunOptions& options) {
  require_valid(options, "run options");
  const std::string name = options.run_name.empty() ? exp.name + "-" + utc_stamp() : options.run_name;
  check_run_name(name);
  Bench bench(exp, host);  // throws ExperimentError on stage-2 problems: nothing written yet
  const ClockKind clock = clock_kind(exp, bench, options);
  RecordingHeader header = run_header(exp, host, bench, clock);

  const std::filesystem::path out = options.output_dir.empty() ? std::filesystem::path(exp.outputs.directory) : options.output_dir;
  check_run_limits(exp, estimate_run(exp, bench, options), out);
  std::filesystem::create_directories(out);
  std::filesystem::path dir = out / name;
  for (int n = 2; std::filesystem::exists(dir); ++n) dir = out / (name + "-" + std::to_string(n));

  RecordingWriter writer(dir, std::move(header), exp.resolved_yaml, options.store);
  RecordingSink sink(writer);
  RunResult result = execute(exp, bench, *make_clock(clock), sink, options);
  result.dir = dir;
  return result;
}

RunResult run_experiment_to(const Experiment& exp, const PluginHost& host, const RunOptions& options, RunSink& sink) {
  require_valid(options, "run options");
  Bench bench(exp, host);
  return execute(exp, bench, *make_clock(clock_kind(exp, bench, options)), sink, options);
}

}  // namespace stend
