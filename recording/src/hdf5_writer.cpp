// The HDF5 run store's writer (hdf5_store.hpp): run.h5 appended to while the run goes, in SWMR
// mode, each channel stored as counts with the counts→SI rule, or counts and SI side by side.
// Layout and durability rules: docs/recording-format.md.
#include "hdf5_chunks.hpp"
#include "hdf5_common.hpp"
#include "hdf5_store.hpp"

#include "stend/recording/hdf5.hpp"
#include "stend/recording/instruments.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// Each channel's codec from the sensor's LSB sizes and ranges and the first samples: counts only
// when every one of them converts exactly (the temperature offset is taken from the first).
std::array<Codec, kChannels> choose_codecs(const SensorInfo& info, const ImuSample* s, std::size_t n) {
  std::array<Codec, kChannels> out;
  for (int ch = 0; ch < kChannels; ++ch) {
    Codec& c = out[static_cast<std::size_t>(ch)];
    const double lsb = ch < 3 ? info.accel_lsb_mps2 : ch < 6 ? info.gyro_lsb_radps : info.temperature_lsb_c;
    const double range = ch < 3 ? info.accel_range_mps2 : ch < 6 ? info.gyro_range_radps : 0.0;
    const bool absent = !has_channel(info, ch < 3 ? Channel::kAx : ch < 6 ? Channel::kGx : Channel::kTemperature);
    if (absent || !(lsb > 0.0) || !std::isfinite(lsb) || n == 0) {  // an absent instrument's NaN
      c.si_stored = true;
      continue;
    }
    c.lsb = lsb;
    if (ch == 6) c.offset = s[0].temperature_c - static_cast<double>(s[0].temperature_counts) * lsb;
    // An MPU-class sensor: ±range is ±32768 counts. Temperature has no range: int16 when the
    // first samples fit (a later one that does not is an exception).
    c.int16 = ch < 6 ? (range > 0.0 && range / lsb <= 32768.5) : true;
    std::size_t exact = 0;
    for (std::size_t i = 0; i < n; ++i) exact += c.exact(counts_of(s[i], ch), si_of(s[i], ch));
    c.si_stored = !std::isfinite(c.offset) || exact < n;
  }
  return out;
}

}  // namespace

struct Hdf5RunWriter::Impl {
  fs::path path;
  RecordingHeader header;
  std::string header_json, experiment_yaml;
  Handle file, samples_group;
  std::array<Codec, kChannels> codec;
  Handle ds_t, ds_flags, ds_counts[kChannels], ds_si[kChannels], ds_exceptions, ds_truth,
      ds_segments, ds_events, ds_summary, ds_status, ds_status_message, ds_end_time;
  // Samples not yet in the file, column by column.
  std::vector<double> t;
  std::vector<std::int32_t> counts[kChannels];
  std::vector<double> si[kChannels];
  std::vector<std::uint32_t> flags;
  ChunkWriter chunks;  // the sample columns' whole chunks
  std::vector<double> exceptions;  // rows of (index, channel, counts, si)
  std::vector<double> truth_rows;  // rows of (t_s, values…)
  std::string segment_bytes, event_bytes;
  std::uint64_t written = 0, gaps = 0, irregular = 0;
  hsize_t exceptions_written = 0, truth_written = 0, segment_bytes_written = 0, event_bytes_written = 0;
  double t_first = std::numeric_limits<double>::quiet_NaN(), t_last = t_first;

  std::size_t pending() const { return t.size(); }
  void create(const ImuSample* first, std::size_t n);
  void write_pending();
  void write_records();
  void write_summary();
};

void Hdf5RunWriter::Impl::create(const ImuSample* first, std::size_t n) {
  silence_hdf5_error_printing();
  codec = choose_codecs(header.info, first, n);
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);  // required by SWMR
  // No chunk cache: each chunk goes to the file when written, so chunks lie in the file in the
  // order of their samples and a file cut short keeps the samples before the cut.
  H5Pset_cache(fapl.get(), 0, 0, 0, 1.0);
  file = check_write(H5Fcreate(path.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, fapl.get()), H5Fclose, path,
                     "cannot create the HDF5 file");
  const hid_t root = file.get();
  put_attr(root, "format", std::string("stend-run"), path);
  put_attr(root, "format_version", std::int64_t{kHdf5FormatVersion}, path);
  put_attr(root, "header_json", header_json, path);
  put_attr(root, "experiment_yaml", experiment_yaml, path);
  put_attr(root, "experiment_name", header.experiment_name, path);
  put_attr(root, "stend_version", header.stend_version, path);
  put_attr(root, "start_time_utc", header.start_time_utc, path);
  put_attr(root, "clock", header.clock, path);
  put_attr(root, "sensor_vendor", header.identity.vendor, path);
  put_attr(root, "sensor_model", header.identity.model, path);
  put_attr(root, "sensor_serial", header.identity.serial, path);
  put_attr(root, "output_rate_hz", header.info.output_rate_hz, path);
  put_attr(root, "gravity_mps2", header.gravity_mps2, path);

  samples_group = check_write(H5Gcreate2(root, "samples", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                              H5Gclose, path, "cannot create group 'samples'");
  const hid_t g = samples_group.get();
  ds_t = create_dataset(g, {"t_s", H5T_IEEE_F64LE, 0, kChunkSamples, true}, path);
  put_attr(ds_t.get(), "unit", std::string("s"), path);
  for (int ch = 0; ch < kChannels; ++ch) {
    const Codec& c = codec[static_cast<std::size_t>(ch)];
    const hid_t type = c.int16 && !c.si_stored ? H5T_STD_I16LE : H5T_STD_I32LE;
    ds_counts[ch] = create_dataset(g, {kCountsNames[ch], type, 0, kChunkSamples, c.si_stored}, path);
    if (c.si_stored) {
      ds_si[ch] = create_dataset(g, {kSiNames[ch], H5T_IEEE_F64LE, 0, kChunkSamples, true}, path);
      put_attr(ds_si[ch].get(), "unit", std::string(kSiUnits[ch]), path);
    } else {
      put_attr(ds_counts[ch].get(), "lsb", c.lsb, path);
      put_attr(ds_counts[ch].get(), "offset", c.offset, path);
      put_attr(ds_counts[ch].get(), "si_name", std::string(kSiNames[ch]), path);
      put_attr(ds_counts[ch].get(), "unit", std::string(kSiUnits[ch]), path);
    }
  }
  ds_flags = create_dataset(g, {"flags", H5T_STD_U32LE, 0, kChunkSamples, true}, path);
  ds_exceptions = create_dataset(g, {"exceptions", H5T_IEEE_F64LE, 4, kSmallChunk / 4, true}, path);
  put_attr(ds_exceptions.get(), "columns", std::string("index,channel,counts,si"), path);

  std::string truth_columns = "t_s";
  for (const auto& c : header.truth_columns) truth_columns += "," + c;
  ds_truth = create_dataset(root, {"truth", H5T_IEEE_F64LE, 1 + header.truth_columns.size(),
                                   std::max<hsize_t>(1, kSmallChunk / (1 + header.truth_columns.size())), true},
                            path);
  put_attr(ds_truth.get(), "columns", truth_columns, path);
  ds_segments = create_dataset(root, {"segments_csv", H5T_STD_U8LE, 0, kSmallChunk, true}, path);
  ds_events = create_dataset(root, {"events_csv", H5T_STD_U8LE, 0, kSmallChunk, true}, path);
  // Fixed-size datasets overwritten in place (the file's metadata does not move when the run
  // ends, so a file cut short keeps its header): summary, status and how the run ended.
  {
    const hsize_t dims[1] = {kSummaryColumns};
    Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
    ds_summary = check_write(H5Dcreate2(root, "summary", H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                                        H5P_DEFAULT, H5P_DEFAULT),
                             H5Dclose, path, "cannot create dataset 'summary'");
    put_attr(ds_summary.get(), "columns",
             std::string("sample_count,gap_count,t_first_s,t_last_s,irregular_interval_count"), path);
  }
  ds_status = create_text(root, "status", kStatusBytes, to_string(RunStatus::kRunning), path);
  ds_status_message = create_text(root, "status_message", kMessageBytes, "", path);
  ds_end_time = create_text(root, "end_time_utc", kTimeBytes, "", path);
  write_summary();
  check_write(H5Fstart_swmr_write(root), path, "cannot start SWMR writing");
}

void Hdf5RunWriter::Impl::write_pending() {
  const hsize_t n = pending();
  if (n == 0) return;
  std::vector<ChunkColumn> columns{{ds_t.get(), H5T_NATIVE_DOUBLE, t.data(), "t_s"}};
  for (int ch = 0; ch < kChannels; ++ch) {
    columns.push_back({ds_counts[ch].get(), H5T_NATIVE_INT32, counts[ch].data(), kCountsNames[ch]});
    if (ds_si[ch]) columns.push_back({ds_si[ch].get(), H5T_NATIVE_DOUBLE, si[ch].data(), kSiNames[ch]});
  }
  columns.push_back({ds_flags.get(), H5T_NATIVE_UINT32, flags.data(), "flags"});
  chunks.write(columns, written, n, path);
  for (int ch = 0; ch < kChannels; ++ch) {
    counts[ch].clear();
    si[ch].clear();
  }
  written += n;
  t.clear();
  flags.clear();
}

void Hdf5RunWriter::Impl::write_records() {
  const hsize_t ne = exceptions.size() / 4;
  write_rows(ds_exceptions.get(), H5T_NATIVE_DOUBLE, exceptions_written, ne, 4, exceptions.data(), path, "exceptions");
  exceptions_written += ne;
  exceptions.clear();
  const hsize_t cols = 1 + header.truth_columns.size();
  const hsize_t nt = truth_rows.size() / cols;
  write_rows(ds_truth.get(), H5T_NATIVE_DOUBLE, truth_written, nt, cols, truth_rows.data(), path, "truth");
  truth_written += nt;
  truth_rows.clear();
  write_rows(ds_segments.get(), H5T_NATIVE_UINT8, segment_bytes_written, segment_bytes.size(), 0,
             segment_bytes.data(), path, "segments_csv");
  segment_bytes_written += segment_bytes.size();
  segment_bytes.clear();
  write_rows(ds_events.get(), H5T_NATIVE_UINT8, event_bytes_written, event_bytes.size(), 0,
             event_bytes.data(), path, "events_csv");
  event_bytes_written += event_bytes.size();
  event_bytes.clear();
}

void Hdf5RunWriter::Impl::write_summary() {
  const double rate_hz = header.info.output_rate_hz;
  const double v[kSummaryColumns] = {static_cast<double>(written), static_cast<double>(gaps), t_first, t_last,
                                     rate_hz > 0.0 ? static_cast<double>(irregular) : -1.0};
  check_write(H5Dwrite(ds_summary.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v), path,
              "cannot write dataset 'summary'");
}

Hdf5RunWriter::Hdf5RunWriter(fs::path file, const RecordingHeader& header, std::string header_json,
                             std::string experiment_yaml)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = std::move(file);
  impl_->header = header;
  impl_->header_json = std::move(header_json);
  impl_->experiment_yaml = std::move(experiment_yaml);
}

Hdf5RunWriter::~Hdf5RunWriter() {
  if (!impl_->file) return;
  try {
    flush();
  } catch (...) {
    // A destructor must not throw; flush()/finish() report write errors.
  }
}

void Hdf5RunWriter::add_samples(const ImuSample* s, std::size_t n) {
  Impl& I = *impl_;
  if (n == 0) return;
  silence_hdf5_error_printing();  // on this thread (an import writes on a thread of its own)
  if (!I.file) I.create(s, n);
  if (std::isnan(I.t_first)) I.t_first = s[0].t_s;
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& x = s[i];
    const std::uint64_t index = I.written + I.pending();
    I.t.push_back(x.t_s);
    for (int ch = 0; ch < kChannels; ++ch) {
      const Codec& c = I.codec[static_cast<std::size_t>(ch)];
      const std::int32_t cnt = counts_of(x, ch);
      const double v = si_of(x, ch);
      if (c.si_stored) {
        I.si[ch].push_back(v);
        I.counts[ch].push_back(cnt);
        continue;
      }
      if (!c.exact(cnt, v)) {
        I.exceptions.insert(I.exceptions.end(),
                            {static_cast<double>(index), static_cast<double>(ch), static_cast<double>(cnt), v});
      }
      I.counts[ch].push_back(std::clamp<std::int32_t>(cnt, c.int16 ? INT16_MIN : INT32_MIN,
                                                      c.int16 ? INT16_MAX : INT32_MAX));
    }
    I.flags.push_back(x.flags);
    I.gaps += (x.flags & kGapBefore) != 0;
    if (index > 0) I.irregular += interval_irregular(x.t_s - I.t_last, I.header.info.output_rate_hz);
    I.t_last = x.t_s;
    // At each chunk boundary, so that after a flush mid-chunk the chunks are again written whole.
    if ((I.written + I.pending()) % kChunkSamples == 0) I.write_pending();
  }
}

void Hdf5RunWriter::add_truth(double t_s, const std::vector<double>& values) {
  impl_->truth_rows.push_back(t_s);
  impl_->truth_rows.insert(impl_->truth_rows.end(), values.begin(), values.end());
}

void Hdf5RunWriter::add_segment_record(std::string_view r) { impl_->segment_bytes.append(r); }
void Hdf5RunWriter::add_event_record(std::string_view r) { impl_->event_bytes.append(r); }

void Hdf5RunWriter::flush() {
  Impl& I = *impl_;
  if (!I.file) return;  // nothing to flush into until the first samples
  silence_hdf5_error_printing();
  I.write_pending();
  I.write_records();
  // The rows reach the file before /summary counts them: /summary is contiguous, so its values go
  // to the file at H5Dwrite, while the datasets' new extents wait in the metadata cache for the
  // flush. Summary first, a kill during the flush could leave it counting rows the file lacks.
  check_write(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
  I.write_summary();
  check_write(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
}

void Hdf5RunWriter::finish(RunStatus status,
                           const std::string& end_time_utc, const std::string& message) {
  Impl& I = *impl_;
  if (!I.file) I.create(nullptr, 0);
  flush();
  write_text(I.ds_status_message.get(), kMessageBytes, message, I.path);
  write_text(I.ds_end_time.get(), kTimeBytes, end_time_utc, I.path);
  check_write(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
  write_text(I.ds_status.get(), kStatusBytes, to_string(status), I.path);  // last: the commit point
  check_write(H5Fflush(I.file.get(), H5F_SCOPE_GLOBAL), I.path, "cannot flush");
}

}  // namespace stend::detail
