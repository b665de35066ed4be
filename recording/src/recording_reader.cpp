// Recording::open: a run folder read back from either store, run.h5 (hdf5_store.hpp) or the CSV
// files (csv_run_store.hpp), every file checked. Format: docs/recording-format.md.
#include "stend/recording/recording.hpp"

#include "csv_run_store.hpp"
#include "hdf5_store.hpp"
#include "run_json.hpp"
#include "store_files.hpp"

#include "stend/errors.hpp"
#include "stend/yaml/reader.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <system_error>
#include <utility>

namespace stend {

namespace fs = std::filesystem;
using detail::read_events;
using detail::read_run_json;
using detail::read_segments;
using detail::read_whole_file;

namespace {

// The experiment's YAML, checked.
void check_experiment_yaml(const fs::path& where, const std::string& text) {
  try {
    (void)yaml::parse_kept(text);  // kept: the analyses read it next
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}:{}: invalid YAML: {}", where.string(), e.mark.line + 1,
                                 e.mark.column + 1, e.msg));
  }
}

// When run.h5's header attributes cannot be read (`damage`), the header the writer also put in
// run.json (and the experiment in experiment.yaml) beside it; without run.json the run is unreadable.
void read_header_beside_damaged_hdf5(const fs::path& file, const std::string& damage, Recording& r) {
  std::error_code ec;
  const fs::path run_json = file.parent_path() / "run.json";
  if (!fs::exists(run_json, ec))
    throw InputError(fmt::format("{}; {} is missing, so the run's header cannot be read", damage, run_json.string()));
  read_run_json(run_json, read_whole_file(run_json), r.header);
  const fs::path yaml = file.parent_path() / "experiment.yaml";
  if (fs::exists(yaml, ec)) {
    r.experiment_yaml = read_whole_file(yaml);
    check_experiment_yaml(yaml, r.experiment_yaml);
  }
}

// run.h5: header, experiment, truth, segments and events; samples behind the file's source.
void open_hdf5(const fs::path& file, Recording& r, SampleLoading loading, TruthLoading truth) {
  detail::Hdf5Run h = detail::open_hdf5_run(file, truth);
  if (h.header_damage.empty()) {
    read_run_json(file.string() + ":header_json", h.header_json, r.header);
    r.experiment_yaml = std::move(h.experiment_yaml);
    check_experiment_yaml(file.string() + ":experiment_yaml", r.experiment_yaml);
  } else {
    read_header_beside_damaged_hdf5(file, h.header_damage, r);
    h.damage = h.header_damage + (h.damage.empty() ? "" : "; " + h.damage);
  }
  r.header.status = h.status;
  if (h.truth_columns != r.header.truth_columns.size() && h.truth_rows > 0) {
    throw InputError(fmt::format("{}: dataset /truth has {} value columns, the header names {}",
                                 file.string(), h.truth_columns, r.header.truth_columns.size()));
  }
  r.truth_t = std::move(h.truth_t);
  r.truth = std::move(h.truth);
  r.truth_store = std::move(h.truth_store);
  r.truth_rows = h.truth_rows;
  csv::Reader segments(file.string() + ":segments_csv", h.segments_csv);
  read_segments(segments, r);
  csv::Reader events(file.string() + ":events_csv", h.events_csv);
  read_events(events, r);
  r.format = RecordingFormat::kHdf5;
  r.written_samples = h.written_samples;
  r.damage = std::move(h.damage);
  r.gap_count = h.gap_count;
  r.irregular_count = h.irregular_count;
  if (loading == SampleLoading::kStream) {
    r.source = std::move(h.samples);
    return;
  }
  r.samples.resize(h.samples->size());
  for_each_chunk(*h.samples, [&](const ImuSample* c, std::size_t n, std::uint64_t first) {
    std::copy(c, c + n, r.samples.begin() + static_cast<std::ptrdiff_t>(first));
  });
}

// The run folder `run_dir` read from run.h5, or else from run.json and the CSV files.
Recording open_run_folder(const fs::path& run_dir, SampleLoading loading, TruthLoading truth) {
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec)) {
    throw InputError(
        fmt::format("{}: not a run directory (it does not exist or is not a folder)", run_dir.string()));
  }
  Recording r;
  r.dir = run_dir;
  const fs::path h5 = run_dir / detail::kHdf5FileName;
  if (fs::exists(h5, ec)) {
    open_hdf5(h5, r, loading, truth);
    return r;
  }
  const fs::path run_json = run_dir / "run.json";
  if (!fs::exists(run_json, ec)) {
    throw InputError(fmt::format(
        "{}: missing; {} is not a Stend recording (or its writer died before starting)",
        run_json.string(), run_dir.string()));
  }
  const nlohmann::json run_json_fields = read_run_json(run_json, read_whole_file(run_json), r.header);

  const fs::path yaml = run_dir / "experiment.yaml";
  if (fs::exists(yaml, ec)) {
    r.experiment_yaml = read_whole_file(yaml);
    check_experiment_yaml(yaml, r.experiment_yaml);
  }
  // A run whose writer was killed before its first samples has run.json alone: no samples.
  if (!fs::exists(run_dir / "imu.csv", ec) && r.header.status == RunStatus::kRunning) {
    r.format = RecordingFormat::kHdf5;
    if (loading == SampleLoading::kStream) r.source = std::make_shared<MemorySamples>(std::vector<ImuSample>{});
    return r;
  }
  detail::open_csv(run_dir, run_json_fields, r, loading, truth);
  return r;
}

}  // namespace

Recording Recording::open(const fs::path& run_dir, SampleLoading loading, TruthLoading truth) {
  try {
    return open_run_folder(run_dir, loading, truth);
  } catch (const InputError&) {
    throw;
  } catch (const IoError&) {
    throw;
  } catch (const std::runtime_error& e) {  // every other reader error is about the folder's content
    throw InputError(e.what());
  }
}

}  // namespace stend
