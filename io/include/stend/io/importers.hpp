// Importers: other tools' files → an in-memory stend::Recording, so every analysis command works
// on public datasets as on our own run folders.
//
// Every importer fills
//   samples   t_s, raw counts where the file has them (else 0) and SI values (m/s², rad/s, °C);
//             kGapBefore where the file's own sample index or timestamps show lost samples
//   header    identity (what the dataset says, else empty), info (output rate, ranges and LSBs
//             where known), gravity_mps2 when the dataset states it (else 0 = unknown),
//             clock "wall", status "complete", experiment_name "import:<format>",
//             experiment_file = the source file
//   segments  the dataset's own annotations: kind "orientation" (a static position; label = the
//             dataset's name for it) or "rotation" (a turn), t_start_s … t_end_s = first … last
//             sample time of the annotated part
//   events    one "info" event (source "import") stating the file and every assumption made
//   dir       the source file
// and throws ImportError, whose message names the file and the 1-based line (text files) or the
// place (binary files: the byte offset, or a record), for malformed input.
#pragma once

#include <stend/errors.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>
#include <stend/recording/truth_columns.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace stend::io {

// A position in a binary file: bytes from its start.
struct ByteOffset {
  std::uint64_t bytes = 0;
};

class ImportError : public InputError {
 public:
  // line = 0 when the problem is not tied to a line.
  ImportError(const std::filesystem::path& file, std::size_t line, const std::string& message);
  // A binary file: the message reads "<file>: byte <offset>: <message>".
  ImportError(const std::filesystem::path& file, ByteOffset offset, const std::string& message);
  // A binary file: `where` names the place ("record 17 (message)", "byte 1234 (chunk)").
  ImportError(const std::filesystem::path& file, const std::string& where, const std::string& message);
  const std::filesystem::path& file() const { return file_; }
  std::size_t line() const { return line_; }
  std::optional<std::uint64_t> offset() const { return offset_; }  // the ByteOffset form
  const std::string& where() const { return where_; }               // the binary forms

 private:
  std::filesystem::path file_;
  std::size_t line_ = 0;
  std::optional<std::uint64_t> offset_;
  std::string where_;
};

// The truth columns importers write where the dataset knows its stimulus: specific force [m/s²]
// and rate [rad/s] in the sensor frame (the names: stend/recording/truth_columns.hpp).
inline const std::vector<std::string> kTruthColumns =
    truth_column_names({kSpecificForceColumns, kRateColumns});

// ---------------------------------------------------------------------------------------------
// (a) Generic delimited text with a column mapping.

// A column by its name in the column-name line, or by 0-based index.
struct CsvColumn {
  std::string name;
  int index = -1;
  CsvColumn() = default;
  CsvColumn(int i) : index(i) {}                    // NOLINT(google-explicit-constructor)
  CsvColumn(const char* n) : name(n ? n : "") {}    // NOLINT(google-explicit-constructor)
  CsvColumn(std::string n) : name(std::move(n)) {}  // NOLINT(google-explicit-constructor)
  bool empty() const { return name.empty() && index < 0; }
};

struct CsvMapping {
  char delimiter = ',';         // ' ' = any run of spaces/tabs
  std::size_t skip_lines = 0;   // lines before the column-name line (or before the data)
  bool column_names = true;     // the first line after skip_lines names the columns
  std::string comment_prefix = "#";  // data lines starting with it are ignored ("" = none)

  CsvColumn time;               // empty: fixed rate, t = i / rate_hz
  double time_scale_s = 1.0;    // seconds per time unit (1e-3 for ms, 1e-9 for ns)
  double rate_hz = 0.0;         // required without a time column; else 0 = from the timestamps
                                // (repaired from this rate when they repeat or jitter)

  std::array<CsvColumn, 3> accel;   // x y z (all empty = no accelerometer: a gyro-only log)
  std::array<CsvColumn, 3> gyro;    // x y z (all empty = no gyroscope); one of the two is required
  CsvColumn temperature;            // optional

  // File value → SI: (value − offset) · scale (m/s² resp. rad/s per file unit or count; the
  // offsets are in file units, e.g. 32768 counts for unsigned 16-bit; °C = value·scale + offset).
  double accel_scale = 1.0;
  double accel_offset_counts = 0.0;
  double gyro_scale = 1.0;
  double gyro_offset_counts = 0.0;
  double temperature_scale = 1.0;
  double temperature_offset_c = 0.0;
  // A sensor's columns hold raw integer counts: they are stored as counts too, and its scale is the
  // LSB (header.info.accel_lsb_mps2 / gyro_lsb_radps / temperature_lsb_c). Chosen per sensor: an
  // accelerometer in counts beside a gyroscope in rad/s is common.
  bool accel_counts = false;
  bool gyro_counts = false;
  bool temperature_counts = true;  // with accelerometer counts: the temperature column holds integer counts too

  SensorIdentity identity;
  double accel_range_mps2 = 0.0;  // header.info, 0 = unknown
  double gyro_range_radps = 0.0;
  double gravity_mps2 = 0.0;      // 0 = unknown
  bool drop_bad_samples = false;  // a bad line (stend/io/plausibility.hpp) dropped and counted, not refused

  // A positive time scale, a rate >= 0, finite non-zero scales, finite offsets, gravity and
  // ranges >= 0. (Which columns the file has is checked against it when it is read.)
  bool IsValid(std::string* error = nullptr) const;
};

Recording import_csv(const std::filesystem::path& file, const CsvMapping& mapping);
// The same, streaming: the samples go to `out` a chunk at a time (through the windowed timestamp
// repair, stend/io/timestamps.hpp); `rec` receives everything else (header filled before the first
// samples reach `out`), no samples, and its events at t = 0 (RunSink places them).
void import_csv(const std::filesystem::path& file, const CsvMapping& mapping, Recording& rec, SampleSink& out);

// ---------------------------------------------------------------------------------------------
// (b) imucal annotated session (mad-lab-fau/imucal example_data/annotated_session.csv):
// columns part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z in raw counts; `samples` is the sample
// index (t = samples / rate). Parts x_p x_a y_p y_a z_p z_a (axis pointing up / down) become
// "orientation" segments, x_rot y_rot z_rot (360° turns about the axis) "rotation" segments.
// Truth (kTruthColumns) from the annotations: an orientation <axis>_p / <axis>_a holds
// f = ±gravity_mps2 along the axis and zero rate (snapshots at its start, middle and end).
//
// Scale: the file has counts only. The defaults are the nominal ±16 g (2048 LSB/g) and
// ±2000 °/s (16.4 LSB/(°/s)) settings that imucal's own calibration of this session
// (example_cal.json: K_a ≈ 208.5 / 208.0 / 214.8 counts per m/s², K_g ≈ 16.68 / 16.19 / 16.25
// counts per °/s) matches to within 3 %; SI values are therefore approximate (uncalibrated).
struct ImucalOptions {
  double rate_hz = 204.8;
  double accel_lsb_per_g = 2048.0;
  double gyro_lsb_per_dps = 16.4;
  double accel_offset_counts = 0.0;  // SI = (count − offset) · LSB
  double gyro_offset_counts = 0.0;
  double gravity_mps2 = 9.81;  // the value imucal's Ferraris calibration assumes (expected_g)

  bool IsValid(std::string* error = nullptr) const;  // rate, LSBs and gravity > 0; finite offsets
};
Recording import_imucal_session(const std::filesystem::path& csv, const ImucalOptions& options = {});
// The same, streaming: a first pass checks every line and finds the runs of increasing sample
// index (the file is grouped by part), the second merges them (one line reader per run) and passes
// the samples to `out` a chunk at a time; `rec` receives the rest (segments, truth, events).
void import_imucal_session(const std::filesystem::path& csv, const ImucalOptions& options, Recording& rec,
                           SampleSink& out);

// ---------------------------------------------------------------------------------------------
// (c) MPU-6050 multi-position session (tomisuarez2/ImuCalibration): a header of `key,value`
// lines (Fs,100 / Logging Type / Initialization time,36.5 / Waiting time) and the column-name
// line ax,ay,az,gx,gy,gz, then raw counts. ±2 g → 16384 LSB/g, ±250 °/s → 131 LSB/(°/s);
// t = i / Fs. The only annotation is the initial still interval (Initialization time > 0):
// one "orientation" segment labelled "initialization" from 0 to that time.
struct Mpu6050MultiposOptions {
  double accel_lsb_per_g = 16384.0;
  double gyro_lsb_per_dps = 131.0;
  double accel_offset_counts = 0.0;  // SI = (count − offset) · LSB
  double gyro_offset_counts = 0.0;
  double gravity_mps2 = 0.0;  // header.gravity_mps2 (0 = unknown: the file does not state it)

  bool IsValid(std::string* error = nullptr) const;  // LSBs > 0, finite offsets, gravity >= 0
};
Recording import_mpu6050_multipos(const std::filesystem::path& csv,
                                  const Mpu6050MultiposOptions& options = {});
// The same, streaming: the samples go to `out` a chunk at a time (the file is read line by line),
// `rec` receives the rest (header filled before the first samples reach `out`).
void import_mpu6050_multipos(const std::filesystem::path& csv, const Mpu6050MultiposOptions& options, Recording& rec,
                             SampleSink& out);

// ---------------------------------------------------------------------------------------------
// (d) IMU-TK text format: one file per triad, one sample per line `t x y z` (whitespace, comma or
// semicolon separated; '#' comments and blank lines ignored). The accelerometer file defines
// the samples; gyro samples are matched by timestamp (identical within time_tolerance_s) or,
// when the files have different timestamps, linearly interpolated at the accelerometer times
// (accelerometer samples outside the gyro's time span are dropped, and an event says so).
struct ImuTkOptions {
  double time_scale_s = 1.0;  // seconds per timestamp unit (IMU-TK: sec, ms, µs or ns)
  double accel_scale = 1.0;   // m/s² per file unit (SI = (value − offset) · scale)
  double accel_offset_counts = 0.0;
  double gyro_scale = 1.0;    // rad/s per file unit
  double gyro_offset_counts = 0.0;
  bool counts = false;        // values are raw counts (stored as counts; scales = LSBs)
  double rate_hz = 0.0;       // 0 = from the median accelerometer interval
  double time_tolerance_s = -1.0;  // < 0: 1 % of the median interval
  SensorIdentity identity;
  double gravity_mps2 = 0.0;

  // A positive time scale, finite non-zero scales, finite offsets, rate and gravity >= 0.
  bool IsValid(std::string* error = nullptr) const;
};
// gyro_file may be empty (accelerometer only).
Recording import_imutk(const std::filesystem::path& acc_file,
                       const std::filesystem::path& gyro_file, const ImuTkOptions& options = {});
// The same, streaming: the two files are read line by line side by side (after a first pass that
// checks them and takes their time spans and the accelerometer's median interval from its first
// kTimestampWindow lines); the samples go to `out` a chunk at a time through the windowed timestamp
// repair, `rec` receives the rest.
void import_imutk(const std::filesystem::path& acc_file, const std::filesystem::path& gyro_file,
                  const ImuTkOptions& options, Recording& rec, SampleSink& out);
// Writes `t x y z` lines (SI values, or counts when `counts`), full double precision; each file is
// replaced whole (stend::write_file_atomic: IoError naming the path when a write fails).
void export_imutk(const Recording& recording, const std::filesystem::path& acc_file,
                  const std::filesystem::path& gyro_file, bool counts = false);

// ---------------------------------------------------------------------------------------------
// (e) MATLAB .mat (v5; v7.3 too when matio was built with HDF5), through matio.
//
// Accepted layout — top-level variables, or the fields of one struct variable (the one named
// `struct_name`, else the first struct in the file):
//   t | time | timestamp      N-vector, time in seconds · time_scale_s   } one of the two
//   fs | rate_hz | rate       scalar sample rate (t = i / fs)             }
//   acc | accel | accelerometer         N×3 (or 3×N) m/s² · accel_scale       (required)
//   gyro | gyr | gyroscope              N×3 (or 3×N) rad/s · gyro_scale       (optional)
//   temp | temperature                  N-vector, °C                           (optional)
//   acc_counts, gyro_counts             N×3 integer counts                     (optional)
//   acc_lsb, gyro_lsb                   scalars: SI per count (give SI from counts when
//                                       acc / gyro are absent)
//   segments                            struct array with fields kind, label (char),
//                                       t_start_s, t_end_s (double)             (optional)
// Any numeric class (double, single, integers) is accepted. Names are matched exactly.
struct MatOptions {
  std::string struct_name;  // empty: top-level variables, else the first struct
  double time_scale_s = 1.0;
  double accel_scale = 1.0;
  double gyro_scale = 1.0;
  SensorIdentity identity;
  double gravity_mps2 = 0.0;

  bool IsValid(std::string* error = nullptr) const;  // a positive time scale, finite non-zero scales, gravity >= 0
};
Recording import_mat(const std::filesystem::path& file, const MatOptions& options = {});
// The same, streaming: the samples go to `out` a block at a time (a compressed v5 variable is
// inflated once, forwards; a v7.3 one read by hyperslabs), `rec` receives the rest.
void import_mat(const std::filesystem::path& file, const MatOptions& options, Recording& rec, SampleSink& out);
// Writes the layout above (t, fs, acc, gyro, temp, acc_counts, gyro_counts, acc_lsb, gyro_lsb,
// segments) in MAT v5: as top-level variables, or as the fields of one struct variable named
// `struct_name` when it is not empty.
void export_mat(const Recording& recording, const std::filesystem::path& file,
                const std::string& struct_name = {});
// ---------------------------------------------------------------------------------------------
// (f) A table of static means against known inputs (the paper's Table 2 form): delimited text
// with a column-name line and '#' comments. Per row the known input: `angle_deg` (a turn δ of the
// paper's table about y: f = g·[−sin δ, 0, cos δ], stend::physics::paper_table with h = 0) or
// f_x_mps2, f_y_mps2, f_z_mps2; and the measured means a_x_mps2, a_y_mps2, a_z_mps2 (any subset;
// an axis the table lacks reads NaN). Each row becomes an "orientation" segment in which its mean
// is held for kStaticTableHold_s at kStaticTableRate_hz (the samples repeat the mean: their std is
// 0 and says nothing about noise), with truth snapshots (kTruthColumns, zero rate) and an event
// saying so. gravity_mps2 = 0: standard gravity, stated as an assumption.
inline constexpr double kStaticTableRate_hz = 10.0;
inline constexpr double kStaticTableHold_s = 20.0;
Recording import_static_table(const std::filesystem::path& file, double gravity_mps2 = 0.0);

// (g) A table of means without known inputs (Magneto's input, many lab spreadsheets): one row per
// orientation, the accelerometer's three means, no time; optionally per row the count n of samples
// averaged and their standard deviation sigma (one for all axes, or one per axis; in the means'
// unit). Columns named by a first line (ax, ay, az or acc_x, a_x, x, …; n, count; sigma, std,
// sigma_x, …: held_rows.hpp and means_table.cpp say which) or, without one, three columns ax ay az.
// Delimiter: comma, semicolon, tab or blanks, from the first line unless given. Each row held as in
// (f), without truth but the held-mean columns (stend/recording/truth_columns.hpp), and an event
// stating the layout found. For the unknown-orientation fit (|g| only).
struct MeansTableOptions {
  char delimiter = 0;              // 0: from the first line
  bool counts = false;             // the means are counts: SI = (value − offset) · accel_scale
  double accel_scale = 1.0;        // SI per file unit (m/s² per g, per count, or 1)
  double accel_offset_counts = 0.0;
  bool unit_stated = false;        // accel_scale was given (--accel-unit / --accel-lsb), not the default
  double gravity_mps2 = 0.0;       // 0 = unknown

  // A finite non-zero scale, a finite offset, gravity >= 0.
  bool IsValid(std::string* error = nullptr) const;
};
Recording import_means_table(const std::filesystem::path& file, const MeansTableOptions& options = {});

// Whether MATLAB files can be read and written (always: matio is required).
bool mat_supported();

// The checks the options of every importer share: a factor that is finite and not 0, a gravity
// that is 0 (unknown) or positive [m/s²].
bool finite_nonzero(double v);
bool gravity_or_unknown(double g_mps2);

}  // namespace stend::io
