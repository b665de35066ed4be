// Shared analysis helpers of the `stend` program: open a recording or dataset, fit a model file.
#include "commands.hpp"
#include "procedure.hpp"
#include "progress.hpp"

#include "stend/errors.hpp"
#include "stend/io/sample_sink.hpp"
#include "stend/estimation/registry.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/recording/files.hpp"
#include "stend/core/memory.hpp"
#include "stend/core/plugin_host.hpp"
#include "stend/recording/samples.hpp"
#include "stend/yaml/reader.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

namespace stend::cli {

void DatasetArgs::add_to(CLI::App* sub, bool required) {
  sub->add_option("input", inputs,
                  "Run folder, or dataset file(s): " + io::format_names() + " (IMU-TK: ACC [GYRO])")
      ->required(required)
      ->expected(1, 2);
  sub->add_option("--format", format, "auto (by content) | " + io::format_names());
  sub->add_option("--mapping", mapping, "YAML file of import keys (the flags below, '_' for '-')");
  sub->add_option("--experiment", experiment,
                  "Experiment file of the procedure the log was recorded with (faces, turns, rate_legs, still): "
                  "aligned to the log, it gives the segments and truth (docs/procedures.md)");
  for (const auto& k : io::import_keys()) {
    // The value is parsed as the import reads it, so that a bad one is refused as a usage error.
    const CLI::Validator parses(
        [key = k.key](std::string& value) -> std::string {
          try {
            io::ImportOptions().set(key, value);
            return {};
          } catch (const std::invalid_argument& e) {
            return e.what();
          }
        },
        "");
    if (k.type == io::ImportKeyType::kSwitch)
      sub->add_flag(io::import_flag(k.key), flags[k.key], k.description())->check(parses);
    else
      sub->add_option(io::import_flag(k.key), flags[k.key], k.description())->type_name(k.type_name())->check(parses);
  }
}

void DatasetArgs::add_accept_damaged(CLI::App* sub) {
  sub->add_flag("--accept-damaged", accept_damaged,
                "Analyse the readable part of a damaged run (a truncated file, rows missing against run.json) "
                "instead of refusing it");
}

io::ImportOptions DatasetArgs::options() const {
  io::ImportOptions o;
  if (!mapping.empty()) io::read_import_mapping(mapping, o);
  for (const auto& k : io::import_keys()) {
    const auto it = flags.find(k.key);
    if (it != flags.end() && !it->second.empty()) o.set(k.key, it->second);  // checked while parsing
  }
  return o;
}

io::Inputs DatasetArgs::paths() const { return io::Inputs(inputs.begin(), inputs.end()); }

namespace {

// Dataset files larger than this in total [bytes] are read through a scratch run store rather than
// into memory: a sample in memory (ImuSample, ~100 B) takes more than its text line, so a 10⁷-row
// CSV would need gigabytes; through the store, analyses read it a chunk at a time.
constexpr std::uintmax_t kInMemoryMaxBytes = std::uintmax_t{32} << 20;

std::uintmax_t total_bytes(const io::Inputs& inputs) {
  std::uintmax_t n = 0;
  std::error_code ec;
  for (const auto& p : inputs)
    if (std::filesystem::is_regular_file(p, ec)) n += std::filesystem::file_size(p, ec);
  return n;
}

// The scratch run folders of this process (under the system's temp folder), removed when it exits.
class ScratchRuns {
 public:
  ~ScratchRuns() {
    std::error_code ec;
    for (const auto& d : dirs_) std::filesystem::remove_all(d, ec);
  }
  // A new, empty folder's path (the folder itself not yet made: RunSink makes it).
  std::filesystem::path make() {
    std::string pattern = (std::filesystem::temp_directory_path() / "stend-scratch-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot make a scratch folder under " + pattern);
    dirs_.emplace_back(pattern);
    return dirs_.back() / "run";
  }

 private:
  std::vector<std::filesystem::path> dirs_;
};

// The dataset imported into a scratch run store and opened from it, its samples streamed.
stend::Recording open_through_store(const io::Inputs& inputs, const std::string& format, const io::ImportOptions& o) {
  static ScratchRuns scratch;
  const std::filesystem::path dir = scratch.make();
  stend::Recording rec;
  io::RunSink sink(rec, dir, "name: " + inputs[0].stem().string() + "\n");
  const bool detect = format.empty() || format == "auto";
  if (!(detect ? io::detect_format(inputs, o) : io::find_format(format)).reads_hdf5) sink.write_in_background();
  io::import_dataset(inputs, format, rec, sink, o);
  rec.header.status = RunStatus::kComplete;
  sink.finish();
  stend::Recording opened = stend::Recording::open(dir, SampleLoading::kStream, TruthLoading::kLoad);
  opened.dir = inputs[0];  // results name the file, as for a dataset read into memory
  return opened;
}

}  // namespace

stend::Recording DatasetArgs::open() const {
  if (!experiment.empty() && is_run())
    throw InputError("--experiment is for a dataset file: the run folder '" + inputs[0] + "' has its procedure already");
  stend::Recording rec = !is_run() && total_bytes(paths()) > kInMemoryMaxBytes
                             ? open_through_store(paths(), format, options())
                             : io::open_dataset(paths(), format, options());
  if (!is_run()) {
    print_read(rec);
    print_warnings(rec);
  }
  checked(rec);
  if (!experiment.empty()) align_recording(rec, load_procedure(experiment));
  return rec;
}

std::string print_read(const stend::Recording& rec) {
  std::string imported;
  for (const auto& e : rec.events) {
    if (e.source != "import" || e.level != "info") continue;
    const bool is_imported = e.message.rfind("imported ", 0) == 0;
    if (!is_imported && e.message.rfind("format ", 0) != 0) continue;
    fmt::print(human(), "read:       {}\n", e.message);
    if (is_imported) imported = e.message;
  }
  return imported;
}

std::vector<std::string> print_warnings(const stend::Recording& rec) {
  std::vector<std::string> warnings;
  for (const auto& e : rec.events)
    if (e.level == "warning") {
      fmt::print(human(), "warning:    {}\n", e.message);
      warnings.push_back(e.message);
    }
  return warnings;
}

std::string unfinished_import(const stend::Recording& rec) {
  if (rec.header.status == RunStatus::kComplete || rec.experiment_yaml.empty()) return {};
  try {
    const YAML::Node root = YAML::Load(rec.experiment_yaml);
    if (!root.IsMap() || !root["import"]) return {};
  } catch (const YAML::Exception&) {
    return {};
  }
  return fmt::format("{}: the import into this run folder did not finish (status {}: stopped or killed while it "
                     "wrote; {} samples of the log are in it)",
                     rec.dir.string(), to_string(rec.header.status), rec.sample_count());
}

const stend::Recording& DatasetArgs::checked(const stend::Recording& rec) const {
  if (accept_damaged) return rec;
  if (const std::string why = unfinished_import(rec); !why.empty())
    throw InputError(why + " — import the log again into a new folder, or --accept-damaged analyses the part imported");
  try {
    require_whole(rec);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) + " — --accept-damaged analyses the readable part");
  }
  return rec;
}

bool DatasetArgs::is_run() const { return inputs.size() == 1 && io::looks_like_run(inputs[0]); }

namespace {

// Estimator plugins found by `host` whose names are not already in `registry`; `host` must
// outlive the registry and every estimator created through it.
void add_plugin_estimators(estimation::Registry& registry, const PluginHost& host) {
  for (const PluginRecord& rec : host.records()) {
    if (rec.info == nullptr || rec.info->kind != STEND_KIND_ESTIMATOR || !rec.shadowed_by.empty()) continue;
    if (registry.find(rec.info->name) != nullptr) continue;  // built in: the same code, linked
    estimation::EstimatorEntry e;
    e.name = rec.info->name;
    e.version = rec.info->version;
    e.description = rec.info->description;
    e.results_file = e.name + ".json";
    e.create = [&host, name = e.name] { return host.create_estimator(name, Params{}); };
    registry.add(std::move(e));
  }
}

// The estimator `name` (or the one the model file is written for, with "auto"): built in, or an
// estimator plugin on the search path. `host` keeps a plugin loaded while it is used.
const estimation::EstimatorEntry& resolve_estimator(const estimation::Registry& registry, PluginHost& host,
                                                    estimation::Registry& with_plugins, const std::string& name,
                                                    const std::string& model_file) {
  if (name == "auto") return registry.for_model(yaml::load_file(model_file, "model file"), model_file);
  if (const auto* e = registry.find(name)) return *e;
  host.scan(PluginHost::default_search_path());
  with_plugins = registry;
  add_plugin_estimators(with_plugins, host);
  if (const auto* e = with_plugins.find(name)) return *e;
  throw InputError("no estimator '" + name + "': not built in (" + registry.names() +
                           ") and no estimator plugin of that name on the search path "
                           "(`stend plugins` lists what is found; STEND_PLUGIN_PATH adds a folder)");
}

}  // namespace

namespace {

// The text copy beside a results document: the same name, ".txt".
std::filesystem::path text_beside(std::filesystem::path json) { return json.replace_extension(".txt"); }

// Whether `json` is the results document of a fit that succeeded (its status "ok"): one that a
// failed fit must not replace. An unreadable file is not one.
bool holds_good_result(const std::filesystem::path& json) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(json, ec)) return false;
  std::ifstream in(json);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  return !doc.is_discarded() && estimation::status_of(doc) == estimation::FitStatus::kOk;
}

// Says on stderr that a good results file was kept and where the failed result went instead.
void say_kept(const WrittenResults& w) {
  fmt::print(stderr,
             "warning: the fit failed; {} (and {}) holds an earlier good result and is kept unchanged; this failed "
             "result is written beside it, to {} (and {})\n",
             w.kept.string(), text_beside(w.kept).filename().string(), w.file.string(),
             text_beside(w.file).filename().string());
}

}  // namespace

std::filesystem::path failed_results_path(const std::filesystem::path& json) {
  return json.parent_path() / ("failed-" + json.filename().string());
}

WrittenResults write_results(std::filesystem::path json, const std::string& document, const std::string& text,
                             bool failed) {
  if (json.empty()) {
    fmt::print(human(), "results:    not written (the input is not a run folder; --out FILE writes them)\n");
    return {};
  }
  WrittenResults w{json, {}};
  if (failed && holds_good_result(json)) w = {failed_results_path(json), json};
  write_file_atomic(w.file, document + "\n");
  write_file_atomic(text_beside(w.file), text);
  if (!w.kept.empty()) say_kept(w);
  if (!failed)
    fmt::print(human(), "results:    {}\n", w.file.string());
  else if (w.kept.empty())
    fmt::print(human(), "results:    none — the fit failed ({} says why)\n", w.file.string());
  else
    fmt::print(human(), "results:    none — the fit failed ({} says why; {}, an earlier good result, is kept)\n",
               w.file.string(), w.kept.string());
  return w;
}

namespace {

// Whether the estimator reads the samples through Recording::sample_source(): every built-in
// one. Plugins written against `samples` get the samples in memory.
bool reads_sample_source(const estimation::Registry& builtin, const estimation::EstimatorEntry& e) {
  const auto& all = builtin.entries();
  return std::any_of(all.begin(), all.end(), [&](const estimation::EstimatorEntry& b) { return b.name == e.name; });
}

// The samples of a stored recording, counting what the fit reads (for its progress line): whole
// samples, and a sixth of a sample per value of one channel (the six sensor channels).
class CountingSource final : public stend::SampleSource {
 public:
  explicit CountingSource(std::shared_ptr<const stend::SampleSource> inner) : inner_(std::move(inner)) {}
  std::uint64_t size() const override { return inner_->size(); }
  void read(std::uint64_t first, std::size_t count, stend::ImuSample* out) const override {
    inner_->read(first, count, out);
    values_ += 6 * count;
  }
  void read_column(stend::Channel c, std::uint64_t first, std::size_t count, double* out) const override {
    inner_->read_column(c, first, count, out);
    values_ += count;
  }
  // Samples read over the recording's samples (passes: 1 = each read once).
  double passes() const {
    const std::uint64_t n = inner_->size();
    return n ? static_cast<double>(values_.load()) / 6.0 / static_cast<double>(n) : 0.0;
  }

 private:
  std::shared_ptr<const stend::SampleSource> inner_;
  mutable std::atomic<std::uint64_t> values_{0};
};

// A recording whose samples and truth take at most this much memory is read into memory once
// before its fit: an estimator's many passes over a short record (a calibration makes about
// twenty) then cost no decoding. Longer records stay in the store, read a chunk at a time.
constexpr std::uint64_t kHeldInMemoryBytes = std::uint64_t{64} << 20;

bool small_enough_to_hold(const stend::Recording& rec) {
  const std::uint64_t truth_values = rec.truth_rows * (rec.header.truth_columns.size() + 1);
  return rec.sample_count() * sizeof(stend::ImuSample) + truth_values * sizeof(double) <= kHeldInMemoryBytes;
}

// What a fit allocates beside the held recording, per sample (the store reader's column buffers,
// the detector's selectors, the intervals' columns: ~84 bytes in a 38-pose calibration), taken
// from the kernel in one call with the recording instead of a page fault per 4 KiB
// (stend/core/memory.hpp; 2 260 → 1 140 faults there).
constexpr std::size_t kFitWorkBytesPerSample = 96;

// The recording with its samples and truth in memory (a copy of what is in the store).
stend::Recording held_in_memory(const stend::Recording& rec) {
  stend::Recording out = rec;
  out.source.reset();
  out.samples.reserve(static_cast<std::size_t>(rec.sample_count()));
  stend::prefault(out.samples.data(), out.samples.capacity() * sizeof(stend::ImuSample));
  out.samples.resize(static_cast<std::size_t>(rec.sample_count()));
  stend::warm_heap(kFitWorkBytesPerSample * out.samples.size());
  if (!out.samples.empty()) rec.sample_source().read(0, out.samples.size(), out.samples.data());
  if (!rec.truth_store) return out;
  out.truth_store.reset();
  const stend::RecordedTruth& store = *rec.truth_store;
  const auto rows = static_cast<std::size_t>(store.rows());
  const std::size_t columns = store.columns();
  std::vector<double> values(rows * columns);
  const auto whole = std::make_unique<bool[]>(rows);
  out.truth_t.resize(rows);
  if (rows) store.read(0, rows, out.truth_t.data(), values.data(), whole.get());
  out.truth.assign(rows, {});
  for (std::size_t i = 0; i < rows; ++i)  // a row with fewer values stays short, as it was read
    if (whole[i]) out.truth[i].assign(values.begin() + static_cast<std::ptrdiff_t>(i * columns),
                                      values.begin() + static_cast<std::ptrdiff_t>((i + 1) * columns));
  return out;
}

}  // namespace

bool fit_reads_truth(const std::string& model_file, const std::string& estimator) {
  const estimation::Registry registry = estimators::builtin();
  PluginHost host;
  estimation::Registry with_plugins;
  return resolve_estimator(registry, host, with_plugins, estimator, model_file).reads_truth;
}

bool results_in_run(const std::filesystem::path& run_dir, const std::filesystem::path& results_file) {
  if (run_dir.empty() || results_file.empty()) return false;
  std::error_code ec;
  return std::filesystem::equivalent(std::filesystem::absolute(results_file).parent_path(), run_dir, ec) && !ec;
}

namespace {
nlohmann::json path_or_null(const std::filesystem::path& p) {
  return p.empty() ? nlohmann::json(nullptr) : nlohmann::json(p.string());
}
}  // namespace

nlohmann::json FitOutcome::to_json() const {
  return {{"ok", ok},
          {"status", estimation::to_string(status)},
          {"estimator", estimator},
          {"results_file", path_or_null(results_file)},
          {"kept_results_file", path_or_null(kept_results_file)},
          {"document", document}};
}

ExitCode FitOutcome::exit_code() const {
  if (ok) return ExitCode::kOk;
  return status == estimation::FitStatus::kNotApplicable ? ExitCode::kInvalidInput : ExitCode::kFitFailed;
}

FitOutcome fit_recording(const stend::Recording& rec, const std::string& model_file, const std::filesystem::path& out_dir,
                         const std::string& json_out, const std::string& estimator) {
  const estimation::Registry registry = estimators::builtin();
  PluginHost host;
  estimation::Registry with_plugins;
  const estimation::EstimatorEntry& entry = resolve_estimator(registry, host, with_plugins, estimator, model_file);
  // Progress on a terminal: the share of the samples read (first pass), then the solve's time.
  std::optional<stend::Recording> counted;
  std::shared_ptr<const CountingSource> counter;
  if (rec.source) {
    counter = std::make_shared<const CountingSource>(rec.source);
    counted = rec;
    counted->source = counter;
  }
  const auto start = std::chrono::steady_clock::now();
  BackgroundProgress progress(
      "fit " + entry.name + ", samples read", [counter] { return counter ? std::min(1.0, counter->passes()) : 1.0; },
      [counter, start] {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return counter && counter->passes() < 1.0 ? std::string("reading the samples")
                                                  : fmt::format("solving, {} elapsed", fmt_duration(s));
      });
  const stend::Recording& input = counted ? *counted : rec;
  std::optional<stend::Recording> in_memory;
  if ((input.source || input.truth_store) && (!reads_sample_source(registry, entry) || small_enough_to_hold(input)))
    in_memory = held_in_memory(input);
  EstimatorRequest request;
  request.recording = in_memory ? &*in_memory : &input;
  request.input = rec.dir.string();
  request.model_file = model_file;
  request.output_dir = out_dir.string();
  const estimation::FitResult r = estimation::fit(entry, request);
  progress.stop();
  std::string text = r.text;
  const std::string& why = r.summary.message;
  if (!r.ok() && !why.empty() && text.find(why) == std::string::npos) text += entry.name + ": FAILED — " + why + "\n";
  std::filesystem::path json = json_out;
  if (json.empty() && !out_dir.empty())
    json = out_dir / estimation::results_file_for(r.results_file, estimation::model_instrument(
                                                                      yaml::load_file(model_file, "model file")));
  human_stream() << text;
  const std::string document = r.written_document();
  FitOutcome out;
  out.ok = r.ok();
  out.status = r.status();
  out.estimator = entry.name;
  out.document = r.document;
  out.result = r;
  if (r.status() == estimation::FitStatus::kNotApplicable) {
    fmt::print(human(), "results:    none — not applicable: {}; nothing written\n", r.summary.message);
    return out;
  }
  const WrittenResults written = write_results(json, document, text, !r.ok());
  out.results_file = written.file;
  out.kept_results_file = written.kept;
  return out;
}

FitCommandOutcome run_fit(const FitArgs& a) {
  const DatasetArgs& data = a.data;
  const RunFolderLock lock = lock_run(data.is_run() ? data.inputs[0] : std::string());  // one command at a time on a run
  // A run opened for an estimator that needs no bench truth (allan) leaves the truth in the store.
  const stend::Recording rec = data.is_run() && !fit_reads_truth(a.model, a.estimator)
                                   ? stend::Recording::open(data.inputs[0], SampleLoading::kStream, TruthLoading::kSkip)
                                   : data.open();
  const std::filesystem::path run_dir = data.is_run() ? std::filesystem::path(data.inputs[0]) : std::filesystem::path();
  FitCommandOutcome o{fit_recording(data.checked(rec), a.model, run_dir, a.out, a.estimator), {}};
  o.doc = o.fit.to_json();
  o.doc["report"] = nullptr;
  if (run_dir.empty()) {
    fmt::print(human(), "report:     none (the input is not a run folder; `stend import` makes one)\n");
  } else if (o.fit.results_file.empty()) {
    fmt::print(human(), "report:     {} not updated (no results written)\n", (run_dir / "report.html").string());
  } else if (results_in_run(run_dir, o.fit.results_file)) {
    // A failed fit too: its results file now says so and the report drops its earlier numbers —
    // unless it was written beside a good results file that it kept (write_results): the report
    // shows that one. The run is recorded in the results store (--db, else the default) as it now
    // stands.
    const std::filesystem::path report = write_run_report(run_dir, a.db);
    fmt::print(human(), "report:     {} (updated)\n", report.string());
    o.doc["report"] = report.string();
  } else {
    fmt::print(human(), "report:     {} not updated (--out put the results outside the run folder)\n",
               (run_dir / "report.html").string());
  }
  return o;
}

}  // namespace stend::cli
