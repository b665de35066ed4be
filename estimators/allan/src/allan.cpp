#include <stend/allan/allan.hpp>
#include <stend/allan/deviation_report.hpp>
#include <stend/errors.hpp>
#include <stend/physics/units.hpp>
#include <stend/model/terms.hpp>
#include <stend/processing/stationarity.hpp>
#include <stend/recording/instruments.hpp>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/ostream.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <array>
#include <cmath>
#include <numbers>
#include <ostream>
#include <exception>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace stend::allan {

// ---------------------------------------------------------------------------------------------
// Options

std::string yaml_location(const std::string& file, const YAML::Node& n) {
  const YAML::Mark m = n.Mark();
  std::string loc = file.empty() ? std::string("<yaml>") : file;
  if (m.line >= 0) loc += fmt::format(":{}:{}", m.line + 1, m.column + 1);
  return loc;
}

namespace {

// The value of one Allan option, read as a number or a boolean; a bad value throws with its location.
struct OptionValue {
  const std::string& file;
  const std::string& key;
  const YAML::Node& v;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("{}: allan option '{}': {}", yaml_location(file, v), key, what));
  }
  double number() const {
    try {
      return v.as<double>();
    } catch (const YAML::Exception&) {
      fail("expected a number, got '" + (v.IsScalar() ? v.Scalar() : std::string("a non-scalar")) + "'");
    }
  }
  // A whole number in [lo, hi]: `range` says which, in the words of AllanOptions::IsValid.
  double whole(double lo, double hi, const char* range) const {
    const double n = number();
    if (!(n >= lo && n <= hi) || n != std::floor(n)) fail(range);
    return n;
  }
  bool boolean() const {
    try {
      return v.as<bool>();
    } catch (const YAML::Exception&) {
      fail("expected true or false");
    }
  }
};

// Reads the option named value.key (its type; ranges are AllanOptions::IsValid's); false for an
// unknown name.
bool read_allan_option(AllanOptions& o, const OptionValue& value) {
  const std::string& key = value.key;
  if (key == "max_m") {
    o.max_m = static_cast<std::uint64_t>(value.whole(1.0, 9.2e18, "must be an integer >= 1 (samples)"));
  } else if (key == "confidence") {
    o.confidence = value.number();
  } else if (key == "edf_from_model") {
    o.edf_from_model = value.boolean();
  } else if (key == "slope_tolerance") {
    o.slope_tolerance = value.number();
  } else if (key == "min_readoff_edf") {
    o.min_readoff_edf = value.number();
  } else if (key == "min_readoff_points") {
    o.min_readoff_points = static_cast<int>(value.whole(-1e9, 1e9, "must be an integer in 1 … 64"));
  } else if (key == "t_begin_s") {
    o.t_begin_s = value.number();
  } else if (key == "t_end_s") {
    o.t_end_s = value.number();
  } else if (key == "lowpass_hz") {
    o.lowpass_hz = value.number();
  } else {
    return false;
  }
  return true;
}

}  // namespace

bool AllanOptions::IsValid(std::string* why) const {
  if (!noise::AnalysisOptions::IsValid(why)) return false;
  if (std::isfinite(t_begin_s) && std::isfinite(t_end_s) && !(t_end_s > t_begin_s)) {
    if (why) *why = "t_end_s: must be after t_begin_s";
    return false;
  }
  return true;
}

AllanOptions options_from_yaml(const YAML::Node& node, const std::string& file) {
  AllanOptions o;
  if (!node || node.IsNull()) return o;
  if (!node.IsMap()) throw InputError(yaml_location(file, node) + ": Allan options must be a mapping");
  static const std::vector<std::string> keys = {"max_m", "confidence", "edf_from_model",
                                                "slope_tolerance", "min_readoff_edf",
                                                "min_readoff_points", "t_begin_s", "t_end_s",
                                                "lowpass_hz", "deviations", "tau"};
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (read_allan_option(o, OptionValue{file, key, kv.second}) || is_deviation_key(key)) continue;
    std::string all;
    for (const auto& k : keys) all += (all.empty() ? "" : ", ") + k;
    throw InputError(fmt::format("{}: unknown allan option '{}' (known: {})", yaml_location(file, kv.first), key, all));
  }
  std::string why;
  if (!o.IsValid(&why)) {
    // why = "KEY: what is wrong": said at the key's value.
    const std::string key = why.substr(0, why.find(':'));
    OptionValue{file, key, node[key]}.fail(why.substr(key.size() + 2));
  }
  return o;
}

// ---------------------------------------------------------------------------------------------
// Recordings and Kalibr

namespace {

// One Kalibr density of one sensor: per axis the identified coefficient, else its slope read-off,
// else (random walk only) its upper bound; the one number is the largest identified axis, else the
// largest read-off, else the largest bound.
struct KalibrDensity {
  double value = kNaN;
  bool identified = false, upper_bound = false;
  std::array<double, 3> axes{kNaN, kNaN, kNaN};
  std::array<Verdict, 3> verdicts{Verdict::kFailed, Verdict::kFailed, Verdict::kFailed};
};

KalibrDensity kalibr_density(const std::vector<const NoiseModel*>& axes, bool random_walk) {
  KalibrDensity d;
  double best_id = kNaN, best_line = kNaN, best_bound = kNaN;
  bool all = !axes.empty();
  auto larger = [](double a, double b) { return std::isfinite(a) && !(a <= b) ? a : b; };
  for (std::size_t k = 0; k < axes.size() && k < 3; ++k) {
    const Coefficient& c = random_walk ? axes[k]->random_walk : axes[k]->white;
    const Readoff& line = random_walk ? axes[k]->random_walk_line : axes[k]->white_line;
    d.verdicts[k] = c.verdict();
    all = all && c.identified;
    if (c.identified) {
      d.axes[k] = c.value;
      best_id = larger(c.value, best_id);
    } else if (c.verdict() == Verdict::kFailed) {
      continue;
    } else if (line.found) {
      d.axes[k] = line.value;
      best_line = larger(line.value, best_line);
    } else if (random_walk) {
      d.axes[k] = c.upper_bound;
      best_bound = larger(c.upper_bound, best_bound);
    }
  }
  d.identified = all;
  d.value = std::isfinite(best_id) ? best_id : std::isfinite(best_line) ? best_line : best_bound;
  d.upper_bound = !std::isfinite(best_id) && !std::isfinite(best_line) && std::isfinite(best_bound);
  return d;
}

}  // namespace

std::vector<Channel> noise_channels(const SensorInfo& info) {
  std::vector<Channel> out = present_channels(info);
  std::erase(out, Channel::kTemperature);
  return out;
}

KalibrParameters kalibr_parameters(const std::vector<ChannelResult>& channels, double rate_hz) {
  KalibrParameters k;
  k.update_rate = rate_hz;
  std::vector<const NoiseModel*> accel, gyro;
  for (const auto& c : channels) {
    if (c.curve.channel.instrument == Instrument::kAccelerometer) accel.push_back(&c.model);
    if (c.curve.channel.instrument == Instrument::kGyroscope) gyro.push_back(&c.model);
  }
  k.accelerometer_present = !accel.empty();
  k.gyroscope_present = !gyro.empty();
  if (!accel.empty()) {
    const KalibrDensity n = kalibr_density(accel, false), w = kalibr_density(accel, true);
    k.accelerometer_noise_density = n.value;
    k.accelerometer_noise_identified = n.identified;
    k.accelerometer_noise_density_axes = n.axes;
    k.accelerometer_noise_verdict = n.verdicts;
    k.accelerometer_random_walk = w.value;
    k.accelerometer_random_walk_identified = w.identified;
    k.accelerometer_random_walk_is_upper_bound = w.upper_bound;
    k.accelerometer_random_walk_axes = w.axes;
    k.accelerometer_random_walk_verdict = w.verdicts;
  }
  if (!gyro.empty()) {
    const KalibrDensity n = kalibr_density(gyro, false), w = kalibr_density(gyro, true);
    k.gyroscope_noise_density = n.value;
    k.gyroscope_noise_identified = n.identified;
    k.gyroscope_noise_density_axes = n.axes;
    k.gyroscope_noise_verdict = n.verdicts;
    k.gyroscope_random_walk = w.value;
    k.gyroscope_random_walk_identified = w.identified;
    k.gyroscope_random_walk_is_upper_bound = w.upper_bound;
    k.gyroscope_random_walk_axes = w.axes;
    k.gyroscope_random_walk_verdict = w.verdicts;
  }
  return k;
}

namespace {

// Sample index range [i0, i1) inside the options' time window [t_begin_s, t_end_s] [s].
IndexRange selected_range(const SampleSource& src, const AllanOptions& options) {
  IndexRange r{0, src.size()};
  if (std::isfinite(options.t_begin_s)) r.first = lower_bound_time(src, options.t_begin_s);
  if (std::isfinite(options.t_end_s)) {
    r.last = lower_bound_time(src, std::nextafter(options.t_end_s, std::numeric_limits<double>::infinity()));
  }
  r.last = std::max(r.first, r.last);
  return r;
}

// Sampling of the selected range, from one pass over time stamps and flags: the rate [Hz] (the
// header's, or 1 / the median of the first kMedianIntervals sample intervals), lost-sample flags
// and intervals off 1/rate by more than 50 %.
struct Sampling {
  double rate_hz = 0.0;
  double t_begin_s = kNaN, t_end_s = kNaN;
  std::uint64_t gaps = 0, irregular = 0;
};
constexpr std::size_t kMedianIntervals = 1u << 16;

Sampling scan_sampling(const SampleSource& src, IndexRange range, double header_rate_hz,
                       const std::string& source) {
  Sampling s;
  s.rate_hz = header_rate_hz;
  std::vector<double> dt;  // intervals [s] seen before the rate is known
  double prev_t = kNaN;
  auto count_irregular = [&](double d) {
    if (interval_irregular(d, s.rate_hz)) ++s.irregular;
  };
  auto fix_rate = [&] {
    if (s.rate_hz > 0.0 || dt.empty()) return;
    std::vector<double> sorted = dt;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double median_dt = sorted[sorted.size() / 2];
    if (!(median_dt > 0.0)) {
      throw InputError(fmt::format(
          "Allan: {}: no output rate in the header and the timestamps do not increase", source));
    }
    s.rate_hz = 1.0 / median_dt;
    for (double d : dt) count_irregular(d);
  };
  // The time and flag columns only (a columnar store decodes no sensor channel for this pass).
  std::vector<double> times(kDefaultChunkSamples), flags(kDefaultChunkSamples);
  for (std::uint64_t first = range.first; first < range.last; first += times.size()) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(times.size(), range.last - first));
    src.read_column(Channel::kTime, first, n, times.data());
    src.read_column(Channel::kFlags, first, n, flags.data());
    for (std::size_t i = 0; i < n; ++i) {
      const double t = times[i];
      if (first + i > range.first) {
        if (static_cast<std::uint32_t>(flags[i]) & kGapBefore) ++s.gaps;
        const double d = t - prev_t;
        if (s.rate_hz > 0.0) count_irregular(d); else dt.push_back(d);
        if (dt.size() == kMedianIntervals) fix_rate();
      } else {
        s.t_begin_s = t;
      }
      prev_t = t;
    }
  }
  fix_rate();
  s.t_end_s = prev_t;
  return s;
}

// The sampling of the whole of a finished, undamaged run from its store's summary (gap and
// irregular-interval counts kept by the writer) and its two end samples; nullopt when the store
// does not state them or only part of the run is selected.
std::optional<Sampling> summarized_sampling(const Recording& rec, IndexRange range) {
  const SampleSource& src = rec.sample_source();
  if (!rec.complete() || !rec.damage.empty() || rec.written_samples != src.size() || range.first != 0 ||
      range.last != src.size() || rec.gap_count < 0 || rec.irregular_count < 0 ||
      !(rec.header.info.output_rate_hz > 0.0)) {
    return std::nullopt;
  }
  Sampling s;
  s.rate_hz = rec.header.info.output_rate_hz;
  s.gaps = static_cast<std::uint64_t>(rec.gap_count);
  s.irregular = static_cast<std::uint64_t>(rec.irregular_count);
  src.read_column(Channel::kTime, range.first, 1, &s.t_begin_s);
  src.read_column(Channel::kTime, range.last - 1, 1, &s.t_end_s);
  return s;
}

void add_sampling_warnings(const Sampling& s, AllanReport& report) {
  if (s.gaps > 0) {
    report.warnings.push_back(fmt::format(
        "{} sample(s) flagged with lost samples before them; Allan deviation assumes uniform "
        "sampling, so intervals near those gaps are distorted",
        s.gaps));
  }
  if (s.irregular > 0) {
    report.warnings.push_back(fmt::format(
        "{} sample interval(s) deviate by more than 50 % from 1/rate = {:.6g} s", s.irregular,
        1.0 / s.rate_hz));
  }
}

// The sensor's output low-pass cutoff [Hz] as the run's experiment.yaml states it
// (bench.sensor.config.lowpass_hz; the simulated IMU's default is 0 = off), NaN when the run does
// not say (imports, sensors without that key).
double stated_lowpass_hz(const Recording& rec) {
  if (rec.experiment_yaml.empty()) return kNaN;
  try {
    const YAML::Node sensor = YAML::Load(rec.experiment_yaml)["bench"]["sensor"];
    if (!sensor) return kNaN;
    if (sensor["config"] && sensor["config"]["lowpass_hz"]) return sensor["config"]["lowpass_hz"].as<double>();
    return sensor["plugin"] && sensor["plugin"].as<std::string>() == "sim_imu" ? 0.0 : kNaN;
  } catch (const YAML::Exception&) {
    return kNaN;  // an unreadable experiment copy: treat the filter as not stated
  }
}

// Allan curve and noise model of channel `column` (ax ay az [m/s²], gx gy gz [rad/s]) over samples
// `range`, read a column chunk at a time through stream s (reset first); the same chunks go to the
// stationarity check's block summary.
ChannelResult analyze_channel(const SampleSource& src, IndexRange range, Channel column, double rate,
                              const AllanOptions& options, OverlappingAllanStream& s, processing::BlockSummary& blocks) {
  std::vector<double> buf(kDefaultChunkSamples);
  s.reset();
  for (std::uint64_t i = range.first; i < range.last;) {
    const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), range.last - i));
    src.read_column(column, i, take, buf.data());
    s.add(buf.data(), take);
    blocks.add(column, i - range.first, buf.data(), take);
    i += take;
  }
  ChannelInfo info;
  info.name = to_string(column);
  info.instrument =
      instrument_of(column) == model::Instrument::kAccelerometer ? Instrument::kAccelerometer : Instrument::kGyroscope;
  return analyze(s, rate, info, options);
}

// The channels (noise_channels) on two threads, each taking the next channel when done with one
// (the channels' noise fits differ in length), with one stream for all its channels, so that
// memory stays at two streams' state; after the channels, the block summary of the stationarity
// check gathers the time and the temperature (when recorded) besides every channel read.
std::vector<ChannelResult> analyze_channels(const SampleSource& src, IndexRange range,
                                            const std::vector<Channel>& columns, bool temperature, double rate,
                                            const AllanOptions& options, processing::BlockSummary& blocks) {
  const int channels = static_cast<int>(columns.size());
  const int items = channels + 1 + (temperature ? 1 : 0);  // the channels, the time, the temperature
  std::vector<ChannelResult> out(columns.size());
  std::atomic<int> next{0};
  std::exception_ptr error[2];
  auto work = [&](int thread) {
    try {
      std::optional<OverlappingAllanStream> s;  // made with this thread's first channel
      for (int item; (item = next.fetch_add(1)) < items;) {
        if (item == channels) {
          blocks.add_column(src, range, Channel::kTime);
        } else if (item > channels) {
          blocks.add_column(src, range, Channel::kTemperature);
        } else {
          if (!s) s.emplace(options.max_m, range.size());
          const auto at = static_cast<std::size_t>(item);
          out[at] = analyze_channel(src, range, columns[at], rate, options, *s, blocks);
        }
      }
    } catch (...) {
      error[thread] = std::current_exception();
      next = items;  // the other thread stops after its current item
    }
  };
  std::thread second(work, 1);
  work(0);
  second.join();
  for (const auto& e : error) if (e) std::rethrow_exception(e);
  return out;
}

// The stationarity check of the range (stend/processing/stationarity.hpp) on the block summary the
// analysis gathered: why it is no noise record, with what to do instead, into report.not_still; a
// warning when it is too short to judge.
void check_still(const processing::BlockSummary& blocks, const SensorInfo& info, AllanReport& report) {
  const processing::Stationarity s = blocks.judge(info);
  if (!s.basis.empty()) report.notes.push_back(s.basis);
  if (!s.judged)
    report.warnings.push_back(fmt::format(
        "the record is too short to check that it is still ({} blocks of {} s; the check needs {})", s.blocks,
        processing::kStationarityBlockS, processing::kMinStationarityIncrements + 1));
  if (s.still()) return;
  const bool moves = std::any_of(s.stretches.begin(), s.stretches.end(),
                                 [](const auto& m) { return m.mover != processing::Mover::kTemperature; });
  const std::string window =
      moves && std::isfinite(s.still_start_s)
          ? fmt::format("give a still stretch as the model's window (allan: t_begin_s: {:.1f}, t_end_s: {:.1f} is "
                        "the longest one) or a still log",
                        s.still_start_s, s.still_end_s)
          : std::string("give a log at a steady temperature, or a window of it (allan: t_begin_s, t_end_s) where "
                        "the temperature holds");
  report.not_still = fmt::format("the record is not still: {}: the Allan deviation needs a still record — {}",
                                 s.describe(), window);
}

}  // namespace

AllanReport analyze_recording(const Recording& rec, const AllanOptions& options) {
  AllanReport report;
  report.source = rec.dir.string();
  if (!rec.header.experiment_name.empty()) report.source += " (" + rec.header.experiment_name + ")";
  const SampleSource& src = rec.sample_source();
  const IndexRange range = selected_range(src, options);
  if (range.size() < 2) {
    throw InputError(fmt::format("Allan: {} has {} sample(s) in the selected time range",
                                         report.source, range.size()));
  }
  report.samples = range.size();
  const std::optional<Sampling> summary = summarized_sampling(rec, range);
  const Sampling sampling = summary ? *summary : scan_sampling(src, range, rec.header.info.output_rate_hz, report.source);
  report.t_begin_s = sampling.t_begin_s;
  report.t_end_s = sampling.t_end_s;
  report.rate_hz = sampling.rate_hz;
  add_sampling_warnings(sampling, report);
  const std::vector<Channel> columns = noise_channels(rec.header.info);
  if (columns.empty()) throw InputError(fmt::format("Allan: {} has neither an accelerometer nor a gyroscope", report.source));
  AllanOptions opt = options;
  if (std::isnan(opt.lowpass_hz)) opt.lowpass_hz = stated_lowpass_hz(rec);
  processing::BlockSummary blocks(range.size(), sampling.rate_hz);
  std::vector<ChannelResult> analysed =
      analyze_channels(src, range, columns, rec.header.info.has_temperature, sampling.rate_hz, opt, blocks);
  check_still(blocks, rec.header.info, report);  // a record that moves has no noise result
  if (!report.not_still.empty()) return report;
  report.channels = std::move(analysed);
  report.kalibr = kalibr_parameters(report.channels, sampling.rate_hz);
  return report;
}

// ---------------------------------------------------------------------------------------------
// Text

namespace {
std::string kalibr_line(const char* key, double v, const char* unit, bool identified, bool upper,
                        const std::array<double, 3>& axes, const std::array<Verdict, 3>& verdicts) {
  std::string status = identified ? "identified on every axis, largest axis"
                       : upper    ? "UPPER BOUND: not identified"
                                  : "not identified on every axis: largest identified axis, else slope read-off";
  if (!std::isfinite(v)) status = "NOT AVAILABLE";
  std::string per_axis;
  for (int k = 0; k < 3; ++k) {
    per_axis += fmt::format("{}{} {} ({})", k ? ", " : "", "xyz"[k],
                            std::isfinite(axes[k]) ? fmt::format("{:.6g}", axes[k]) : "-", to_string(verdicts[k]));
  }
  return fmt::format("{}: {}  # [{}] {}; per axis: {}\n", key, std::isfinite(v) ? fmt::format("{:.6g}", v) : "null",
                     unit, status, per_axis);
}
}  // namespace

void write_kalibr_yaml(std::ostream& os, const KalibrParameters& k) {
  os << "# IMU noise parameters (Kalibr imu.yaml) from the Allan deviation. Kalibr takes one density\n"
        "# per sensor: the largest axis is written, every axis is in the comment.\n";
  if (k.accelerometer_present) {
    os << kalibr_line("accelerometer_noise_density", k.accelerometer_noise_density, "m/s^2/sqrt(Hz)",
                      k.accelerometer_noise_identified, false, k.accelerometer_noise_density_axes,
                      k.accelerometer_noise_verdict);
    os << kalibr_line("accelerometer_random_walk", k.accelerometer_random_walk, "m/s^3/sqrt(Hz)",
                      k.accelerometer_random_walk_identified, k.accelerometer_random_walk_is_upper_bound,
                      k.accelerometer_random_walk_axes, k.accelerometer_random_walk_verdict);
  } else {
    os << "# accelerometer_*: left out — the recording has no accelerometer\n";
  }
  if (k.gyroscope_present) {
    os << kalibr_line("gyroscope_noise_density", k.gyroscope_noise_density, "rad/s/sqrt(Hz)",
                      k.gyroscope_noise_identified, false, k.gyroscope_noise_density_axes, k.gyroscope_noise_verdict);
    os << kalibr_line("gyroscope_random_walk", k.gyroscope_random_walk, "rad/s^2/sqrt(Hz)",
                      k.gyroscope_random_walk_identified, k.gyroscope_random_walk_is_upper_bound,
                      k.gyroscope_random_walk_axes, k.gyroscope_random_walk_verdict);
  } else {
    os << "# gyroscope_*: left out — the recording has no gyroscope\n";
  }
  os << fmt::format("update_rate: {:.6g}  # [Hz]\n", k.update_rate);
}

std::ostream& operator<<(std::ostream& os, const KalibrParameters& k) {
  write_kalibr_yaml(os, k);
  return os;
}

namespace {
// A table cell of one coefficient's verdict: value ± σ, <= bound, or FAILED.
std::string verdict_cell(const Coefficient& c, double factor = 1.0) {
  switch (c.verdict()) {
    case Verdict::kIdentified: return fmt::format("{:.4g}±{:.2g}", c.value * factor, c.sigma * factor);
    case Verdict::kUpperBound:
      return std::isfinite(c.upper_bound) ? fmt::format("<={:.3g}", c.upper_bound * factor) : std::string("n/i");
    case Verdict::kFailed: return "FAILED";
  }
  return "?";
}
}  // namespace

void write_summary_table(std::ostream& os, const AllanReport& r) {
  os << fmt::format("{:<4} {:>18} {:>18} {:>18} {:>18} {:>18} {:>18} {:>16} | {:>10} {:>10} {:>10}  {}\n", "axis", "N",
                    "K", "B", "G (GM sigma)", "Tc [s]", "Q", "R", "N@1s line", "K@3s line", "B=min/.664", "units");
  auto rcell = [](const Readoff& x) {
    return x.found ? fmt::format("{:.4g}", x.value)
                   : (std::isfinite(x.value) ? fmt::format("<={:.3g}", x.value) : std::string("-"));
  };
  for (const auto& c : r.channels) {
    const auto& m = c.model;
    const auto& u = c.curve.units;
    os << fmt::format("{:<4} {:>18} {:>18} {:>18} {:>18} {:>18} {:>18} {:>16} | {:>10} {:>10} {:>10}  N {}, K {}, B {}, G {}, Q {}, R {}\n",
                      c.curve.channel.name, verdict_cell(m.white), verdict_cell(m.random_walk),
                      verdict_cell(m.bias_instability), verdict_cell(m.gauss_markov),
                      m.correlation_time.identified ? verdict_cell(m.correlation_time) : std::string("-"),
                      verdict_cell(m.quantization), verdict_cell(m.rate_ramp), rcell(m.white_line),
                      rcell(m.random_walk_line), rcell(m.bias_floor), u.white, u.random_walk, u.bias, u.gauss_markov,
                      u.quantization, u.ramp);
  }
  // Datasheet units of the same verdicts (identified value ± σ, or the upper bound).
  for (const auto& c : r.channels) {
    std::string line;
    for (const Coefficient* coef : {&c.model.white, &c.model.random_walk, &c.model.bias_instability, &c.model.gauss_markov}) {
      for (const auto& conv : datasheet_units(*coef, c.curve.channel.instrument)) {
        line += fmt::format("{}{} {} {}", line.empty() ? "" : ", ", coef->symbol, verdict_cell(*coef, conv.factor), conv.unit);
      }
    }
    if (!line.empty()) os << fmt::format("{:<4} {}\n", c.curve.channel.name, line);
  }
}

std::ostream& operator<<(std::ostream& os, const AllanReport& r) {
  os << fmt::format("Allan analysis of {}: {} samples at {:.6g} Hz, t = {:.6g} … {:.6g} s\n",
                    r.source, r.samples, r.rate_hz, r.t_begin_s, r.t_end_s);
  for (const auto& w : r.warnings) os << "WARNING: " << w << "\n";
  for (const auto& n : r.notes) os << "note: " << n << "\n";
  if (!r.not_still.empty()) return os << "FAILED — " << r.not_still << "\n";
  for (const auto& c : r.channels) os << "\n" << c;
  os << "\n";
  write_summary_table(os, r);
  os << "\n";
  write_kalibr_yaml(os, r.kalibr);
  return os;
}

// ---------------------------------------------------------------------------------------------
// JSON

namespace {
using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json to_json(const Coefficient& c, Instrument instrument) {
  json datasheet = json::array();
  for (const auto& conv : datasheet_units(c, instrument)) {
    datasheet.push_back({{"unit", conv.unit},
                         {"value", num(c.value * conv.factor)},
                         {"sigma", num(c.sigma * conv.factor)},
                         {"upper_bound", c.identified ? json(nullptr) : num(c.upper_bound * conv.factor)}});
  }
  return {{"symbol", c.symbol},   {"name", c.name},
          {"unit", c.unit},       {"verdict", to_string(c.verdict())},
          {"identified", c.identified},
          {"value", num(c.value)}, {"sigma", num(c.sigma)},
          {"interval95", c.identified ? json::array({num(c.lo), num(c.hi)}) : json(nullptr)},
          {"fitted", num(c.fitted)}, {"fitted_sigma", num(c.fitted_sigma)},
          {"dominates", c.dominates}, {"upper_bound", c.identified ? json(nullptr) : num(c.upper_bound)},
          {"dominates_tau_s", c.dominates ? json::array({c.tau_lo_s, c.tau_hi_s}) : json(nullptr)},
          {"datasheet", datasheet}};
}

json to_json(const Readoff& r) {
  return {{"name", r.name},     {"unit", r.unit},   {"found", r.found},
          {"value", num(r.value)}, {"lo", num(r.lo)}, {"hi", num(r.hi)},
          {"tau_s", json::array({num(r.tau_lo_s), num(r.tau_hi_s)})},
          {"note", r.note}};
}

json to_json(const ChannelResult& r) {
  json pts = json::array();
  for (const auto& p : r.curve.points) {
    pts.push_back({{"tau_s", p.tau_s},      {"m", p.m},           {"terms", p.terms},
                   {"avar", num(p.avar)},   {"adev", num(p.adev)}, {"adev_lo", num(p.adev_lo)},
                   {"adev_hi", num(p.adev_hi)}, {"edf", num(p.edf)},
                   {"noise", to_string(p.noise)}});
  }
  const NoiseModel& m = r.model;
  const Instrument inst = r.curve.channel.instrument;
  json model = {{"ok", m.ok},
                {"message", m.message},
                {"selection", m.selection},
                {"chi2_reduced", num(m.chi2_reduced)},
                {"dof", m.dof},
                {"lowpass_hz", num(m.lowpass_hz)},
                {"tau_range_s", json::array({num(m.tau_min_s), num(m.tau_max_s)})},
                {"tau_fit_range_s", json::array({num(m.tau_fit_min_s), num(m.tau_fit_max_s)})},
                {"readoffs",
                 {{"N_line", to_json(m.white_line)},
                  {"K_line", to_json(m.random_walk_line)},
                  {"B_floor", to_json(m.bias_floor)}}}};
  for (int j = 0; j < NoiseModel::kCoefficients; ++j) model[m.coefficients()[j].symbol] = to_json(m.coefficients()[j], inst);
  return {{"channel", r.curve.channel.name},
          {"instrument", to_string(r.curve.channel.instrument)},
          {"unit", r.curve.units.signal},
          {"rate_hz", r.curve.rate_hz},
          {"samples", r.curve.samples},
          {"confidence", r.curve.confidence},
          {"points", pts},
          {"model", model}};
}

// Per-axis Kalibr values {x, y, z} and their verdicts.
json axes(const std::array<double, 3>& v, const std::array<Verdict, 3>& verdicts) {
  json j = json::object();
  for (int k = 0; k < 3; ++k) j[std::string(1, "xyz"[k])] = {{"value", num(v[k])}, {"verdict", to_string(verdicts[k])}};
  return j;
}

json to_json(const KalibrParameters& k) {
  return {{"accelerometer_noise_density", num(k.accelerometer_noise_density)},
          {"accelerometer_random_walk", num(k.accelerometer_random_walk)},
          {"gyroscope_noise_density", num(k.gyroscope_noise_density)},
          {"gyroscope_random_walk", num(k.gyroscope_random_walk)},
          {"update_rate", num(k.update_rate)},
          {"units",
           {{"accelerometer_noise_density", "m/s^2/sqrt(Hz)"},
            {"accelerometer_random_walk", "m/s^3/sqrt(Hz)"},
            {"gyroscope_noise_density", "rad/s/sqrt(Hz)"},
            {"gyroscope_random_walk", "rad/s^2/sqrt(Hz)"},
            {"update_rate", "Hz"}}},
          {"accelerometer_noise_identified", k.accelerometer_noise_identified},
          {"accelerometer_random_walk_identified", k.accelerometer_random_walk_identified},
          {"accelerometer_random_walk_is_upper_bound", k.accelerometer_random_walk_is_upper_bound},
          {"gyroscope_noise_identified", k.gyroscope_noise_identified},
          {"gyroscope_random_walk_identified", k.gyroscope_random_walk_identified},
          {"gyroscope_random_walk_is_upper_bound", k.gyroscope_random_walk_is_upper_bound},
          {"per_axis",
           {{"accelerometer_noise_density", axes(k.accelerometer_noise_density_axes, k.accelerometer_noise_verdict)},
            {"accelerometer_random_walk", axes(k.accelerometer_random_walk_axes, k.accelerometer_random_walk_verdict)},
            {"gyroscope_noise_density", axes(k.gyroscope_noise_density_axes, k.gyroscope_noise_verdict)},
            {"gyroscope_random_walk", axes(k.gyroscope_random_walk_axes, k.gyroscope_random_walk_verdict)}}}};
}
}  // namespace

void write_json(std::ostream& os, const ChannelResult& result, int indent) {
  os << to_json(result).dump(indent) << "\n";
}

bool report_failed(const AllanReport& r) {
  if (r.channels.empty()) return true;
  return std::any_of(r.channels.begin(), r.channels.end(), [](const ChannelResult& c) { return !c.model.ok; });
}

void write_json(std::ostream& os, const AllanReport& r, int indent) {
  json ch = json::array();
  for (const auto& c : r.channels) ch.push_back(to_json(c));
  json j = {{"schema", kSchema},
            {"estimator", {{"name", kEstimatorName}, {"version", kEstimatorVersion}}},
            {"status", report_failed(r) ? "failed" : "ok"},
            {"source", r.source},
            {"rate_hz", r.rate_hz},
            {"samples", r.samples},
            {"t_range_s", json::array({num(r.t_begin_s), num(r.t_end_s)})},
            {"warnings", r.warnings},
            {"notes", r.notes},
            {"channels", ch},
            {"kalibr", to_json(r.kalibr)}};
  if (!r.not_still.empty()) j["message"] = r.not_still;
  os << j.dump(indent) << "\n";
}

}  // namespace stend::allan
