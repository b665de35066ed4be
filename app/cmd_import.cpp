// stend import FILE… -o RUN: another tool's log → a run folder, so that every analysis command
// (info, fit, gap, report, export, compare) works on it. The dataset is read whole through the io/
// format registry first; the folder is created only then, and removed again if writing fails.
#include "commands.hpp"
#include "procedure.hpp"
#include "progress.hpp"

#include "stend/io/formats.hpp"
#include "stend/yaml/reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <future>
#include <memory>
#include <optional>

namespace stend::cli {

namespace {

// Passes the samples on and shows how far the input files have been read.
class ProgressSink final : public io::SampleSink {
 public:
  ProgressSink(io::SampleSink& inner, const io::Inputs& inputs) : inner_(inner), inputs_(inputs) {}
  void add_samples(const ImuSample* samples, std::size_t count) override {
    inner_.add_samples(samples, count);
    samples_ += count;
    if (progress_.due())
      progress_.update(input_read_share(inputs_), fmt::format("{} samples", samples_));
  }
  void clear() { progress_.clear(); }

 private:
  io::SampleSink& inner_;
  const io::Inputs& inputs_;
  TaskProgress progress_{"import"};
  std::uint64_t samples_ = 0;
};

// What was imported and how: format, absolute sources, the options stated.
void emit_import_block(YAML::Emitter& out, const ImportArgs& a, const std::string& format, const io::ImportOptions& options) {
  out << YAML::Key << "import" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << format;
  out << YAML::Key << "sources" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : a.data.paths()) yaml::emit_string(out, std::filesystem::absolute(p).lexically_normal().string());
  out << YAML::EndSeq << YAML::Key << "options" << YAML::Value << YAML::BeginSeq;
  for (const auto& s : options.stated) yaml::emit_string(out, s);
  out << YAML::EndSeq << YAML::EndMap;
}

// experiment.yaml of an imported run: with --experiment the procedure (resolved) and the import;
// else there was no experiment, and it records what was imported and how.
std::string import_yaml(const ImportArgs& a, const std::string& format, const io::ImportOptions& options,
                        const Experiment* procedure) {
  YAML::Emitter out;
  if (procedure) {
    out << YAML::Comment("made by `stend import --experiment`: the procedure the log was recorded with, aligned to it");
    out << YAML::BeginMap;
    const YAML::Node resolved = YAML::Load(procedure->resolved_yaml);
    for (auto it = resolved.begin(); it != resolved.end(); ++it) out << YAML::Key << it->first << YAML::Value << it->second;
  } else {
    out << YAML::Comment("made by `stend import` from another tool's log: there was no experiment");
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value;
    yaml::emit_string(out, a.name.empty() ? "import:" + format : a.name);
  }
  emit_import_block(out, a, format, options);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

// What an import made, on stdout (human lines); returns it as JSON (docs/schemas/import.schema.json).
nlohmann::json print_imported(const std::filesystem::path& dir, const std::string& format, std::uint64_t samples,
                              const Recording& rec) {
  fmt::print(human(), "run folder: {}\nformat:     {}\nrecorded:   {} samples, {} segments, {} truth rows, {} events\n",
             dir.string(), format, samples, rec.segments.size(), rec.truth_t.size(), rec.events.size());
  const std::string read = print_read(rec);  // the layout, the names read, how sensors were joined
  const std::vector<std::string> warnings = print_warnings(rec);
  return {{"run_dir", dir.string()},
          {"format", format},
          {"read", read},
          {"samples", samples},
          {"segments", rec.segments.size()},
          {"truth_rows", rec.truth_t.size()},
          {"events", rec.events.size()},
          {"warnings", warnings}};
}

// Whether `dir` is a complete run folder that this very import made already: the same
// experiment.yaml (format, absolute sources, options, name) and the same provenance events
// (each source's size and sha256, this Stend's version). Running the same command again is then
// a no-op, as with make; anything else in `dir` stays untouched and is an error.
bool already_imported(const std::filesystem::path& dir, const std::string& yaml_text, const io::Inputs& inputs,
                      const std::string& format) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(dir / "experiment.yaml", ec)) return false;
  try {
    if (yaml::read_file((dir / "experiment.yaml").string(), "experiment file") != yaml_text) return false;
    const Recording old = Recording::open(dir, SampleLoading::kStream, TruthLoading::kSkip);
    if (old.header.status != RunStatus::kComplete || !old.damage.empty()) return false;
    Recording now;
    io::add_provenance(now, inputs, format);
    for (const auto& e : now.events) {
      const auto same = [&e](const Event& o) { return o.message == e.message; };
      if (std::none_of(old.events.begin(), old.events.end(), same)) return false;
    }
    return true;
  } catch (const std::exception&) {
    return false;  // not a readable run folder: not this import's
  }
}

// unfinished_import() of the run folder `dir`; "" when it is none (or not a readable run).
std::string unfinished_import_in(const std::filesystem::path& dir) {
  try {
    return unfinished_import(Recording::open(dir, SampleLoading::kStream, TruthLoading::kSkip));
  } catch (const std::exception&) {
    return {};
  }
}

// The sources' provenance events, their SHA-256 taken on a thread beside the import: a pass over
// every byte of the inputs that would otherwise follow the import's own. When the import fails the
// pass is told to stop, and ends within 64 KiB.
class Fingerprints {
 public:
  Fingerprints(const io::Inputs& inputs, const std::string& format)
      : pass_(std::async(std::launch::async, [this, inputs, format] {
          Recording r;
          io::add_provenance(r, inputs, format, &stop_);
          return std::move(r.events);
        })) {}
  ~Fingerprints() {
    stop_ = true;
    if (pass_.valid()) pass_.wait();
  }
  Fingerprints(const Fingerprints&) = delete;
  Fingerprints& operator=(const Fingerprints&) = delete;

  std::vector<Event> events() { return pass_.get(); }

 private:
  std::atomic<bool> stop_{false};
  std::future<std::vector<Event>> pass_;
};

}  // namespace

Outcome run_import(const ImportArgs& a) {
  const std::filesystem::path dir = a.output;
  const io::ImportOptions options = a.data.options();
  const io::Inputs inputs = a.data.paths();
  if (a.data.is_run())
    throw Refusal(ExitCode::kInvalidInput, fmt::format("stend import: '{}' is a run folder already", inputs[0].string()));
  // experiment.yaml names the format, written with the first samples: the format is chosen first.
  const bool detect = a.data.format.empty() || a.data.format == "auto";
  const std::string format = (detect ? io::detect_format(inputs, options) : io::find_format(a.data.format)).name;
  const std::optional<Experiment> procedure =
      a.data.experiment.empty() ? std::nullopt : std::optional<Experiment>(load_procedure(a.data.experiment));
  const std::string yaml_text = import_yaml(a, format, options, procedure ? &*procedure : nullptr);
  if (std::filesystem::exists(dir)) {
    if (!already_imported(dir, yaml_text, inputs, format)) {
      const std::string unfinished = unfinished_import_in(dir);
      throw Refusal(ExitCode::kInvalidInput,
                    unfinished.empty()
                        ? fmt::format("stend import: '{}' exists; give a new folder with -o (nothing was written)", dir.string())
                        : fmt::format("stend import: {}; remove the folder and import again (nothing was written)", unfinished));
    }
    fmt::print(human(), "already imported: {} holds these sources (same sha256), format and options; nothing to do\n",
               dir.string());
    const Recording done = Recording::open(dir, SampleLoading::kStream);
    return {ExitCode::kOk, print_imported(dir, format, done.sample_count(), done)};
  }
  Recording rec;
  Fingerprints fingerprints(inputs, format);
  io::RunSink sink(rec, dir, yaml_text, a.name.empty() && procedure ? procedure->name : a.name);
  if (!io::find_format(format).reads_hdf5) sink.write_in_background();
  try {
    std::optional<AligningSink> aligning;
    if (procedure) aligning.emplace(rec, sink, *procedure);
    ProgressSink shown(aligning ? static_cast<io::SampleSink&>(*aligning) : sink, inputs);
    io::import_dataset(inputs, a.data.format, rec, shown, options);
    shown.clear();
    if (aligning) aligning->finish();
    for (Event& e : fingerprints.events()) rec.events.push_back(std::move(e));
    rec.header.status = RunStatus::kComplete;
    sink.finish();
  } catch (...) {
    sink.abandon();
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);  // the folder did not exist before: nothing else is lost
    throw;
  }
  return {ExitCode::kOk, print_imported(dir, format, sink.sample_count(), rec)};
}

void add_import_command(CLI::App& app, std::vector<Command>& out) {
  auto args = std::make_shared<ImportArgs>();
  auto* sub = app.add_subcommand("import", "Turn another tool's log into a run folder (then info, fit, gap, "
                                           "report, export and compare work on it)");
  args->data.add_to(sub);
  sub->add_option("-o,--output", args->output, "The run folder to create (must not exist, unless it is this same import already: then nothing is done)")->required();
  sub->add_option("--name", args->name, "The recording's name (default import:<format>)");
  add_json_flag(sub, "the run folder made and what it holds");
  out.push_back({sub, [args] {
                   const Outcome o = run_import(*args);
                   print_json(o.doc);
                   return o.code;
                 }});
}

}  // namespace stend::cli
