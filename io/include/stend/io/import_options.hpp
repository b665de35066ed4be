// How to read a log whose layout or units the file does not state: one set of keys, read from
// `stend import|fit` flags (--KEY with '_' written '-') and from a YAML mapping file
// (`--mapping FILE`, the same keys). Every key is declared once, in import_keys().
//
//   delimiter: ","          one character; "space" = runs of spaces/tabs, "tab"
//   skip_lines: 0           lines before the column-name line (or the data)
//   column_names: true      the first line after skip_lines names the columns
//   comment: "#"            data lines starting with it are ignored ("" = none)
//   time: t                 time column, by name or 0-based index (absent: t = i / rate_hz)
//   time_unit: s            s | ms | us | ns
//   rate_hz: 0              the sample rate; without a time column it is required; with one, the
//                           rate repeated or jittering timestamps are rebuilt from (0 = fitted)
//   accel: [ax, ay, az]     accelerometer x y z columns (flag: --accel ax,ay,az)
//   gyro: [gx, gy, gz]      gyroscope x y z columns (absent: no gyroscope)
//   temperature: temp       temperature column (degC = value * temperature_scale + temperature_offset_c)
//   accel_unit: m/s^2       m/s^2 | g            (values in physical units)
//   gyro_unit: rad/s        rad/s | deg/s
//   accel_lsb: 1/16384 g    the values are counts of this size: NUMBER[/NUMBER] UNIT
//   accel_offset: 0         counts; SI = (count - offset) * lsb (e.g. 32768 for unsigned 16-bit)
//   gyro_lsb: 1/131 deg/s
//   gyro_offset: 0
//   temperature_scale: 1
//   temperature_offset_c: 0
//   gravity_mps2: 0         local gravity, 0 = unknown (standard gravity where one is needed)
//   topic: /imu/data        ROS bags: the Imu topic (absent: the bag's only one)
//   temperature_topic: ""   ROS bags: a Temperature topic
//   instance: 0             ULog / DataFlash: the IMU instance (absent: the one with most samples)
//
// The LSB and offset keys apply to every format that holds counts (csv, imutk, imucal,
// mpu6050_multipos): they replace the format's nominal LSB.
#pragma once

#include <stend/io/importers.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace stend::io {

// A triad's file values → SI: counts (lsb > 0: SI = (count − offset)·lsb) or physical units
// (SI = value · unit).
struct ValueScale {
  double lsb = 0.0;     // SI per count; 0 = the file holds physical units
  double offset = 0.0;  // counts
  double unit = 1.0;    // SI per file unit when lsb == 0
  bool counts() const { return lsb > 0.0; }
};

struct ImportOptions {
  char delimiter = ',';
  std::size_t skip_lines = 0;
  bool column_names = true;
  std::string comment = "#";
  CsvColumn time;
  double time_scale_s = 1.0;  // seconds per time unit
  double rate_hz = 0.0;
  std::array<CsvColumn, 3> accel, gyro;
  CsvColumn temperature;
  ValueScale accel_value, gyro_value;
  double temperature_scale = 1.0;
  double temperature_offset_c = 0.0;
  double gravity_mps2 = 0.0;
  std::string topic;              // ROS bags
  std::string temperature_topic;  // ROS bags
  int instance = -1;              // ULog / DataFlash; −1 = the instance with the most samples
  // Every key set, as "key: value" in the order given (the import's provenance states them).
  std::vector<std::string> stated;

  // Sets `key` from its text (a flag's value or a YAML scalar; lists as "a,b,c"). Throws
  // std::invalid_argument naming the key and what was expected.
  void set(const std::string& key, const std::string& value);
  bool was_stated(const std::string& key) const;
  // Ceres style: false with the first problem in *message.
  bool IsValid(std::string* message = nullptr) const;
  // Whether columns are mapped (the generic csv format then applies).
  bool maps_columns() const { return !accel[0].empty(); }
  CsvMapping csv_mapping() const;
};

struct ImportKey {
  std::string key;   // YAML key; the flag is --key with '_' as '-'
  std::string help;  // one line, with the accepted values
};
const std::vector<ImportKey>& import_keys();

// "--accel-lsb" for "accel_lsb".
std::string import_flag(const std::string& key);

// Reads a YAML mapping of import keys into `options` (keys given there override what `options`
// holds). Throws ExperimentError at FILE:LINE:COL for an unknown key or a bad value.
void read_import_mapping(const std::filesystem::path& file, ImportOptions& options);

}  // namespace stend::io
