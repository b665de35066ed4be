// The HDF5 run store's reader (hdf5_store.hpp): run.h5 opened only after its metadata passed the
// damage checks (hdf5_damage.hpp), then its header, summary, truth, records and samples read in
// that order; what is damaged past the header is reported and the rest kept. Layout and damage
// rules: docs/recording-format.md.
#include "hdf5_common.hpp"
#include "hdf5_damage.hpp"
#include "hdf5_metadata.hpp"
#include "hdf5_sources.hpp"
#include "hdf5_store.hpp"

#include "stend/errors.hpp"
#include "stend/recording/hdf5.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <system_error>
#include <utility>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// --- attributes and datasets as read ------------------------------------------------------------

bool is_variable_string_attr(hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) return false;
  Handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle t(a ? H5Aget_type(a.get()) : H5I_INVALID_HID, H5Tclose);
  return t && H5Tis_variable_str(t.get()) > 0;
}

// A scalar string attribute: fixed-length (format 2) or variable-length (format 1, read only after
// the global heap was checked).
std::string get_string_attr(hid_t obj, const char* name, const fs::path& file, GlobalHeapGuard& heap) {
  Handle a = check(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file,
                   fmt::format("attribute '{}' is missing or damaged", name));
  Handle ft(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (H5Tget_class(ft.get()) != H5T_STRING || value_count(space.get()) != 1)
    fail(file, fmt::format("attribute '{}' is not one string (damaged)", name));
  if (H5Tis_variable_str(ft.get()) > 0) {
    heap.check();
    const Handle t = vl_string_type();
    char* p = nullptr;
    check(H5Aread(a.get(), t.get(), &p), file, fmt::format("cannot read attribute '{}'", name));
    std::string s = p ? p : "";
    H5Dvlen_reclaim(t.get(), space.get(), H5P_DEFAULT, &p);
    return s;
  }
  std::error_code ec;
  const std::size_t n = H5Tget_size(ft.get());
  if (n == 0 || n > fs::file_size(file, ec))
    fail(file, fmt::format("attribute '{}' declares a string of {} bytes, not 1 to the file's size (damaged)", name, n));
  const Handle t = fixed_string_type(n);
  std::string s(n, '\0');
  check(H5Aread(a.get(), t.get(), s.data()), file, fmt::format("cannot read attribute '{}'", name));
  s.resize(std::strlen(s.c_str()));
  return s;
}
double get_double_attr(hid_t obj, const char* name, const fs::path& file) {
  Handle a = check(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, file,
                   fmt::format("attribute '{}' is missing or damaged", name));
  Handle ft(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  const H5T_class_t cls = H5Tget_class(ft.get());
  if ((cls != H5T_INTEGER && cls != H5T_FLOAT) || value_count(space.get()) != 1)
    fail(file, fmt::format("attribute '{}' is not one number (damaged)", name));
  double v = 0.0;
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v), file, fmt::format("cannot read attribute '{}'", name));
  return v;
}

Handle open_dataset(hid_t loc, const char* name, const fs::path& file, const char* where) {
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  // A modest cache: one uncompressed chunk of a double column (512 KiB) and a little more.
  H5Pset_chunk_cache(dapl.get(), 101, std::size_t{1} << 20, 1.0);
  Handle ds = check(H5Dopen2(loc, name, dapl.get()), H5Dclose, file,
                    fmt::format("dataset {}{} is missing or damaged", where, name));
  // Stend writes numbers and bytes only: a variable-length or reference type (whose values libhdf5
  // would look up in the global heap) is damage.
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (!type || H5Tis_variable_str(type.get()) != 0 || H5Tdetect_class(type.get(), H5T_VLEN) != 0 ||
      H5Tdetect_class(type.get(), H5T_REFERENCE) != 0)
    fail(file, fmt::format("dataset {}{} has a variable-length or reference type, not a number (damaged)", where, name));
  return ds;
}

std::string read_bytes(hid_t ds, const fs::path& file, const char* name) {
  std::string s(extent_rows(ds), '\0');
  if (read_rows(ds, H5T_NATIVE_UINT8, 0, s.size(), 0, s.data()) < 0)
    fail(file, fmt::format("dataset /{} is damaged", name));
  return s;
}

void add_damage(Hdf5Run& run, const std::string& what) { run.damage += (run.damage.empty() ? "" : "; ") + what; }

// --- the steps of reading run.h5 ---------------------------------------------------------------

// The file opened for reading (SWMR: a file whose writer is still running or was killed, its
// status flags still saying "open for SWMR writing", opens; a finished one the same way), after
// libhdf5's metadata passed the checks: libhdf5 decodes only object headers Stend has checked
// (hdf5_metadata.hpp), those it reads to open the file, then every linked object's, visited before
// anything else is opened.
Handle open_checked(const fs::path& path, Hdf5HeaderCheck& headers) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  // A truncated file is opened anyway (the library's "skip_eof_check" file-access property, which
  // h5clear uses): what lies past the end reads as damaged, and the samples before it are kept.
  hbool_t skip_eof_check = 1;
  if (H5Pexist(fapl.get(), "skip_eof_check") > 0) H5Pset(fapl.get(), "skip_eof_check", &skip_eof_check);
  // A metadata block that fails its checksum is damage, not a write in progress: no retries (SWMR
  // readers otherwise retry 100 times with growing sleeps).
  H5Pset_metadata_read_attempts(fapl.get(), 2);
  auto refuse = [&](const std::string& why) {
    throw InputError(fmt::format("{}: cannot be opened as an HDF5 run store: {}", path.string(), why));
  };
  if (const std::string why = headers.at_open(); !why.empty()) refuse(why);
  Handle file = check(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, fapl.get()),
                      H5Fclose, path, "cannot be opened as an HDF5 run store (damaged or not HDF5)");
  if (const std::string why = check_linked_headers(file.get(), headers); !why.empty()) refuse(why);
  return file;
}

// Whether the header attributes can be read, with the format and its version checked when they
// can. Format 1's string attributes live in the global heap: when that is damaged the header cannot
// be read from this file (Recording::open takes it from run.json; run.header_damage says why), the
// samples still can.
bool check_format(hid_t root, const fs::path& path, GlobalHeapGuard& heap, Hdf5Run& run) {
  const bool header_readable = !is_variable_string_attr(root, "format") || heap.damage().empty();
  if (!header_readable) {
    run.header_damage = heap.damage();
    return false;
  }
  if (!has_attr(root, "format") || get_string_attr(root, "format", path, heap) != "stend-run")
    fail(path, "not a Stend run store, or its header is damaged (attribute format = 'stend-run' cannot be read)");
  const double version = get_double_attr(root, "format_version", path);
  if (version < 1 || version > kHdf5FormatVersion) {
    throw InputError(fmt::format("{}: format_version {} is not readable by this Stend (reads 1..{})",
                                 path.string(), version, kHdf5FormatVersion));
  }
  return true;
}

RunStatus read_status(hid_t root, const fs::path& path) {
  const std::string status = read_text(root, "status", path);
  const auto st = run_status_from_string(status);
  if (!st) fail(path, fmt::format("attribute 'status' is '{}', not a run status", status));
  return *st;
}

// /summary: the samples written as of the last flush (returned; −1 unknown), the gap and irregular
// interval counts (into run). Values that are not counts are damage.
double read_summary(hid_t root, const fs::path& path, Hdf5Run& run) {
  double summary_samples = -1.0;
  Handle ds = open_dataset(root, "summary", path, "/");
  // Files from before the irregular-interval count hold 4 columns.
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  hsize_t dims[1] = {0};
  const bool whole = H5Sget_simple_extent_dims(space.get(), dims, nullptr) == 1 && dims[0] <= kSummaryColumns;
  double v[kSummaryColumns] = {-1, -1, 0, 0, -1};
  if (whole && H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0) {
    // Counts (samples, gaps, irregular intervals), −1 for unknown: anything else is damage.
    auto count = [](double x) { return x >= -1.0 && x <= 9007199254740992.0 && x == std::floor(x); };
    if (count(v[0]) && count(v[1]) && count(v[4])) {
      summary_samples = v[0];
      run.gap_count = static_cast<std::int64_t>(v[1]);
      run.irregular_count = static_cast<std::int64_t>(v[4]);
    } else {
      add_damage(run, fmt::format("{}: dataset /summary holds {:g}, {:g} and {:g} where counts of samples, gaps and "
                                  "irregular intervals belong",
                                  path.string(), v[0], v[1], v[4]));
    }
  }
  H5Eclear2(H5E_DEFAULT);
  return summary_samples;
}

// /truth: its shape, and its rows read (kLoad), left behind a RecordedTruth (kStream) or only
// counted (kSkip).
void read_truth(hid_t root, const fs::path& path, TruthLoading truth, Hdf5Run& run) {
  Handle ds = open_dataset(root, "truth", path, "/");
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  run.truth_rows = dims[0];
  run.truth_columns = dims[1] > 0 ? static_cast<std::size_t>(dims[1] - 1) : 0;
  if (truth == TruthLoading::kSkip) return;
  if (truth == TruthLoading::kStream) {
    run.truth_store = hdf5_truth(path, std::move(ds), dims[0], static_cast<std::size_t>(dims[1]));
    return;
  }
  std::vector<double> v(dims[0] * dims[1]);
  if (read_rows(ds.get(), H5T_NATIVE_DOUBLE, 0, dims[0], dims[1], v.data()) < 0)
    fail(path, "dataset /truth is damaged");
  for (hsize_t r = 0; r < dims[0]; ++r) {
    run.truth_t.push_back(v[r * dims[1]]);
    run.truth.emplace_back(v.begin() + static_cast<std::ptrdiff_t>(r * dims[1] + 1),
                           v.begin() + static_cast<std::ptrdiff_t>((r + 1) * dims[1]));
  }
}

// Truth, segments and events: a damaged one is reported and left empty; the samples stay.
void read_records(hid_t root, const fs::path& path, TruthLoading truth, Hdf5Run& run) {
  auto keep_going = [&](auto&& read) {
    try {
      read();
    } catch (const InputError& e) {
      add_damage(run, e.what());
    }
  };
  keep_going([&] { read_truth(root, path, truth, run); });
  keep_going([&] { run.segments_csv = read_bytes(open_dataset(root, "segments_csv", path, "/").get(), path, "segments_csv"); });
  keep_going([&] { run.events_csv = read_bytes(open_dataset(root, "events_csv", path, "/").get(), path, "events_csv"); });
}

// The datasets of /samples into `c` with each channel's codec; returns the rows every one holds.
// `open` lists the column datasets, for the truncation check.
std::uint64_t open_sample_columns(hid_t g, const fs::path& path, Hdf5SampleColumns& c, std::vector<hid_t>& open) {
  c.t = open_dataset(g, "t_s", path, "/samples/");
  c.flags = open_dataset(g, "flags", path, "/samples/");
  std::uint64_t n = std::min(extent_rows(c.t.get()), extent_rows(c.flags.get()));
  open = {c.t.get(), c.flags.get()};
  for (int ch = 0; ch < kChannels; ++ch) {
    const auto k = static_cast<std::size_t>(ch);
    c.counts[k] = open_dataset(g, kCountsNames[ch], path, "/samples/");
    n = std::min<std::uint64_t>(n, extent_rows(c.counts[k].get()));
    open.push_back(c.counts[k].get());
    if (H5Lexists(g, kSiNames[ch], H5P_DEFAULT) > 0) {
      c.si[k] = open_dataset(g, kSiNames[ch], path, "/samples/");
      n = std::min<std::uint64_t>(n, extent_rows(c.si[k].get()));
      open.push_back(c.si[k].get());
      c.codec[k].si_stored = true;
    } else {
      c.codec[k].lsb = get_double_attr(c.counts[k].get(), "lsb", path);
      c.codec[k].offset = get_double_attr(c.counts[k].get(), "offset", path);
      Handle type(H5Dget_type(c.counts[k].get()), H5Tclose);
      c.codec[k].int16 = H5Tget_size(type.get()) == 2;  // read in the stored width
    }
  }
  return n;
}

// The samples that can be read of the `n` the columns hold, against the summary's count (the writer
// extends the datasets before it records their rows in /summary: fewer rows than recorded is
// damage, and so is any difference once the run finished) and the file's length (a truncated file
// keeps the samples whose chunks are all inside it). run.written_samples: what the writer wrote.
std::uint64_t readable_samples(const fs::path& path, std::uint64_t n, double summary_samples,
                               const std::vector<hid_t>& columns, Hdf5Run& run) {
  if (summary_samples >= 0.0 && (summary_samples > static_cast<double>(n) ||
                                 (run.status != RunStatus::kRunning && summary_samples != static_cast<double>(n)))) {
    add_damage(run, fmt::format("{}: dataset /samples holds {} rows, dataset /summary records {} written",
                                path.string(), n, static_cast<std::uint64_t>(summary_samples)));
  }
  run.written_samples = summary_samples > static_cast<double>(n) ? static_cast<std::uint64_t>(summary_samples) : n;
  std::error_code ec;
  const std::uint64_t file_size = fs::file_size(path, ec);
  const hsize_t chunks = (n + kChunkSamples - 1) / kChunkSamples;
  hsize_t good = chunks;
  for (hid_t ds : columns) good = std::min(good, first_missing_chunk(ds, chunks, file_size));
  if (good == chunks) return n;
  add_damage(run, fmt::format("the file is truncated or damaged after sample {} of {} (a chunk of "
                              "the samples lies outside the file or cannot be located)",
                              good * kChunkSamples, n));
  return good * kChunkSamples;
}

// /samples/exceptions, sorted by sample index. Without its exceptions a counts channel would give
// wrong SI values: this one is required.
std::vector<std::array<double, 4>> read_exceptions(hid_t g, const fs::path& path) {
  Handle ds = open_dataset(g, "exceptions", path, "/samples/");
  const hsize_t rows = extent_rows(ds.get());
  std::vector<std::array<double, 4>> exceptions(rows);
  if (read_rows(ds.get(), H5T_NATIVE_DOUBLE, 0, rows, 4, exceptions.data()) < 0)
    fail(path, "dataset /samples/exceptions (the samples whose SI is not counts·lsb + offset) is damaged");
  std::stable_sort(exceptions.begin(), exceptions.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
  return exceptions;
}

// /samples behind a SampleSource that keeps `file` open.
void read_samples(Handle file, const fs::path& path, double summary_samples, Hdf5Run& run) {
  Handle g = check(H5Gopen2(file.get(), "samples", H5P_DEFAULT), H5Gclose, path,
                   "group /samples is missing or damaged");
  Hdf5SampleColumns c;
  std::vector<hid_t> columns;
  const std::uint64_t held = open_sample_columns(g.get(), path, c, columns);
  const std::uint64_t n = readable_samples(path, held, summary_samples, columns, run);
  c.exceptions = read_exceptions(g.get(), path);
  run.samples = hdf5_samples(path, std::move(file), n, std::move(c));
}

void read_hdf5_run(const fs::path& path, TruthLoading truth, Hdf5Run& run) {
  silence_hdf5_error_printing();
  Hdf5Lock lock;
  Hdf5HeaderCheck headers(path);
  Handle file = open_checked(path, headers);
  const hid_t root = file.get();
  GlobalHeapGuard heap(path, root);
  const bool header_readable = check_format(root, path, heap, run);
  run.status = read_status(root, path);
  if (header_readable) run.header_json = get_string_attr(root, "header_json", path, heap);
  const double summary_samples = read_summary(root, path, run);
  if (header_readable) run.experiment_yaml = get_string_attr(root, "experiment_yaml", path, heap);
  read_records(root, path, truth, run);
  read_samples(std::move(file), path, summary_samples, run);
}

}  // namespace

Hdf5Run open_hdf5_run(const fs::path& path, TruthLoading truth) {
  Hdf5Run run;
  try {
    read_hdf5_run(path, truth, run);
  } catch (const InputError& e) {
    if (run.header_damage.empty()) throw;
    // A damaged global heap first: it is what the rest of the damage most likely goes with.
    throw InputError(fmt::format("{}; besides, {}", run.header_damage, e.what()));
  }
  return run;
}

}  // namespace stend::detail

namespace stend {
void silence_hdf5_error_printing() {
  // Per thread: a thread-safe libhdf5 (Debian's) keeps the printing setting per thread.
  thread_local bool silenced = false;
  if (!silenced) H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  silenced = true;
}
}  // namespace stend
