// The format registry: every file kind `stend fit|gap|import` reads, in one table. A format is
//   name         what --format takes
//   description  one line for the help and for "cannot tell the format" errors
//   detect       whether an input is of this kind, by its content (never by its name);
//                nullptr: only chosen by --format (or, for csv, by mapped columns; for records,
//                by a stated record_layout)
//   open         inputs → Recording, with the import options (LSB, offsets, columns, rate, g)
//   max_inputs   how many files one dataset may take (IMU-TK: the accelerometer and gyro files)
//   stream       (optional) the same as open with the samples passed to a SampleSink in chunks
// Adding a format is one line in formats() (src/formats.cpp), e.g.
//   {"ulog", "PX4 ULog: sensor_accel / sensor_gyro with temperature", looks_like_ulog,
//    [](const Inputs& in, const ImportOptions&) { return import_ulog(in[0]); }},
#pragma once

#include <stend/io/import_options.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace stend::io {

using Inputs = std::vector<std::filesystem::path>;

struct Format {
  std::string name;
  std::string description;
  bool (*detect)(const std::filesystem::path& file) = nullptr;
  Recording (*open)(const Inputs& inputs, const ImportOptions& options) = nullptr;
  std::size_t max_inputs = 1;
  // inputs → `rec` without its samples, which go to `out` a chunk at a time (memory bounded
  // independently of the log's length); nullptr: `open`, then its samples to the sink.
  void (*stream)(const Inputs& inputs, const ImportOptions& options, Recording& rec, SampleSink& out) = nullptr;
  // Whether the import options' column keys (--accel, --gyro, --time, --temperature) name what is
  // inside (variables, arrays, fields): such a format is still detected by content when they are
  // given; otherwise given columns mean the generic csv format.
  bool takes_names = false;
  // Whether the source is read through libhdf5 (a run.h5, MAT 7.3 through matio): then nothing
  // else may call libhdf5 while it is read (RunSink::write_in_background).
  bool reads_hdf5 = false;
};

// Every format, in detection order (the first whose detect() accepts the input wins).
const std::vector<Format>& formats();

// "run | mat | imucal | …" for help texts.
std::string format_names();

// The format named `name`; throws std::invalid_argument listing the formats when unknown.
const Format& find_format(const std::string& name);

// The format of `inputs` by content: raw records when `options` state a record_layout; else the
// first format that detects every input (when `options` map
// columns, among the formats that take names); else the generic csv format when `options` map
// columns. Throws
// InputError listing every format with its description when nothing matches.
const Format& detect_format(const Inputs& inputs, const ImportOptions& options = {});

// The dataset: `format` ("auto" or empty: detect_format) opened with `options`. Checks the input
// count and the options (IsValid). The recording's events state the format and every stated key;
// *used (when given) receives the format's name.
Recording open_dataset(const Inputs& inputs, const std::string& format, const ImportOptions& options = {},
                       std::string* used = nullptr);

// open_dataset into `rec` with the samples passed to `out` a chunk at a time (through the format's
// stream when it has one — every format but the tables of means —, else read whole first) and not
// kept in `rec`.
void import_dataset(const Inputs& inputs, const std::string& format, Recording& rec, SampleSink& out,
                    const ImportOptions& options = {}, std::string* used = nullptr);

// Provenance of the inputs as events (source "import"): path, size, SHA-256, format, Stend
// version. For `stend import`, which makes a run folder of the recording. The SHA-256 is a pass
// over every byte of the inputs: setting `*stop` abandons it (an InputError) within 64 KiB.
void add_provenance(Recording& rec, const Inputs& inputs, const std::string& format,
                    const std::atomic<bool>* stop = nullptr);

// Content checks the formats use, exposed for tests.
bool looks_like_run(const std::filesystem::path& p);
bool looks_like_mat(const std::filesystem::path& p);  // MAT v5 header, HDF5 (v7.3) signature, or a v4 matrix header
bool looks_like_imucal(const std::filesystem::path& p);
bool looks_like_mpu6050_multipos(const std::filesystem::path& p);
bool looks_like_imutk(const std::filesystem::path& p);  // text: each data line 't x y z'
bool looks_like_static_table(const std::filesystem::path& p);
// A table of means without inputs: named ax, ay, az columns (and only n / sigma beside them, no
// time), or three numbers a line; and its first rows turn by more than 2° from one to the next
// (a log's consecutive samples do not).
bool looks_like_means_table(const std::filesystem::path& p);
bool looks_like_npy(const std::filesystem::path& p);  // the .npy magic, or a zip whose first member is a *.npy

}  // namespace stend::io
