// How to read a log whose layout or units the file does not state: one set of keys, given as
// `stend import|fit|gap` flags (--KEY with '_' written '-') or in a YAML mapping file (`--mapping
// FILE`, the same keys; flags override it). Every key — its name, the type of its value, its unit,
// its default, its check and its help — is declared once, in import_keys(); the flags are
// registered and the mapping file read from that table (`stend import --help` lists them).
//
// The LSB and offset keys apply to every format that holds counts (csv, imutk, imucal,
// mpu6050_multipos): they replace the format's nominal LSB.
#pragma once

#include <stend/io/importers.hpp>

#include <filesystem>
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

// One field of a raw binary record (record_layout "t:f64,ax:i16,_:u8"): an array of its own.
struct RecordField {
  std::string name;       // "_": padding, skipped
  char kind = 'f';        // 'i' signed integer, 'u' unsigned integer, 'f' IEEE float
  std::size_t bytes = 8;  // 1, 2, 4 or 8 (i8 … u64); floats 4 (f32) or 8 (f64)
  bool padding() const { return name == "_"; }
};

// The import options, as the keys of import_keys() set them. A default-constructed ImportOptions
// holds every key's default (ImportKey::fallback); a key without one is absent until given (an
// empty column, rate_hz 0, instance −1, no LSB).
struct ImportOptions {
  ImportOptions();

  char delimiter{};
  std::size_t skip_lines{};
  bool column_names{};
  std::string comment;
  CsvColumn time;
  double time_scale_s{};  // seconds per time unit
  double rate_hz{};       // 0: not given
  std::array<CsvColumn, 3> accel, gyro;
  CsvColumn temperature;
  ValueScale accel_value, gyro_value;
  double temperature_scale{};
  double temperature_offset_c{};
  double gravity_mps2{};          // 0: unknown
  std::string topic;              // ROS bags
  std::string temperature_topic;  // ROS bags
  int instance = -1;              // ULog / DataFlash; −1 (not given) = the instance with the most samples
  bool drop_bad_samples{};        // bad samples dropped and counted instead of refused (plausibility.hpp)
  bool accept_implausible{};      // a still |a| far from 1 g (or |w| beyond any MEMS gyro) imported as it is
  std::vector<RecordField> record_layout;  // raw binary records; empty: not given
  bool big_endian{};                       // raw records' byte order
  std::size_t header_bytes{};              // raw records: bytes before the first record
  // Every key set, as "key: value" in the order given (the import's provenance states them).
  std::vector<std::string> stated;

  // Sets `key` from its text (a flag's value or a YAML scalar; lists as "a,b,c"), parsed and
  // checked as its ImportKey says. Throws std::invalid_argument naming the key and what was expected.
  void set(const std::string& key, const std::string& value);
  bool was_stated(const std::string& key) const;
  // What one key cannot say alone: accel and gyro columns each x, y and z, one array's name, or
  // none; a time or temperature column only with an instrument's (one of the two is enough: a
  // gyro-only or an accelerometer-only log); offsets only with an LSB; a byte order or header only
  // with a record layout. Ceres style: false with the first problem in *error.
  bool IsValid(std::string* error = nullptr) const;
  // Whether columns are mapped (the accelerometer's, the gyroscope's or both; the generic csv
  // format then applies).
  bool maps_columns() const;
  CsvMapping csv_mapping() const;
};

// What kind of text an import key takes.
enum class ImportKeyType {
  kText,       // any text
  kCharacter,  // one character, "space" or "tab"
  kCount,      // a whole number >= 0
  kBoolean,    // true | false (yes | no, 1 | 0)
  kSwitch,     // a flag given alone (--KEY: true); in a mapping file true | false
  kNumber,     // a finite number
  kColumn,     // a column: its name, or its 0-based index
  kColumns,    // three columns x,y,z (names or 0-based indices)
  kUnit,       // one of the units the help lists
  kLsb,        // the size of one count: NUMBER[/NUMBER] UNIT
};

// One import key, declared once.
struct ImportKey {
  std::string key;       // YAML key; the flag is --key with '_' as '-' (import_flag)
  ImportKeyType type;
  std::string unit;      // of a number ("Hz", "m/s^2", "counts", …); "" for none
  std::string fallback;  // the default, as the key's text; "" = none (absent until given)
  std::string help;      // what it means and the values it accepts

  // The value's placeholder in a usage line: "NUMBER", "COLUMN", "X,Y,Z", …
  const char* type_name() const;
  // One line for --help: the help, the unit and the default ("…, in Hz [0]").
  std::string description() const;
};
const std::vector<ImportKey>& import_keys();

// "--accel-lsb" for "accel_lsb".
std::string import_flag(const std::string& key);

// Reads a YAML mapping of import keys into `options` (keys given there override what `options`
// holds). Throws ExperimentError at FILE:LINE:COL for an unknown key or a bad value.
void read_import_mapping(const std::filesystem::path& file, ImportOptions& options);

}  // namespace stend::io
