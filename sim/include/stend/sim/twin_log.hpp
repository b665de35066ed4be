// The twin's logs with the quirks real logs have: a CSV of a played procedure's samples
// (stend/sim/procedure_player.hpp) written the way other loggers write them, with the import keys
// that read it back (`stend import LOG <flags>`, stend/io/import_options.hpp). The quirks:
//
//   no_time   no time column: the import needs --rate-hz
//   low_rate  a 16 Hz log of a sensor with its low-pass at 5 Hz (the player's rate, the sensor's filter)
//   bursty    the logger stamps samples as they arrive, in bursts: groups of burst_size samples
//             burst_spacing_s apart, the groups spaced so that the mean rate is the true one
//   counts    raw counts instead of SI: the import needs --accel-lsb and --gyro-lsb (the sensor's LSB)
//   short     holds and legs as short as the procedure allows (about 0.7 × record_s, 1.5 s when
//             none is stated): the player's HandOptions
//
// One table names the quirks each shipped procedure's twin has (shipped_twins): the tests and the
// coverage bench read the same.
#pragma once

#include <stend/sim/procedure_player.hpp>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace stend::sim {

enum class Quirk { kNoTime, kLowRate, kBursty, kCounts, kShort };

// "no_time", "low_rate", "bursty", "counts", "short".
const char* quirk_name(Quirk q);
// The quirk named `name`; throws std::invalid_argument listing the names.
Quirk quirk_from_name(const std::string& name);
// "no_time, counts" (or "none").
std::string quirk_list(const std::vector<Quirk>& quirks);

struct CsvQuirks {
  bool no_time = false;
  bool counts = false;
  bool bursty = false;
  int burst_size = 5;              // samples per burst
  double burst_spacing_s = 0.001;  // between the samples of a burst [s]
};

// What the quirks change in the play (rate, filter, holds) and in the writing.
struct TwinSetup {
  PlayerOptions player;
  SimImuConfig sensor;
  CsvQuirks csv;
};
TwinSetup twin_setup(const std::vector<Quirk>& quirks, std::uint64_t seed);

// The import keys that read a twin CSV written with `csv` (key, value: `stend import` takes them as
// --key value with '_' written '-').
using ImportKeys = std::vector<std::pair<std::string, std::string>>;
ImportKeys twin_import_keys(const CsvQuirks& csv, const Played& played);
// " --time t_s --accel ax,ay,az …" (values quoted for a shell where needed).
std::string import_flags(const ImportKeys& keys);

// Writes the played samples as CSV with the quirks; returns the import keys that read it.
ImportKeys write_twin_csv(const std::filesystem::path& file, const Played& played, const CsvQuirks& csv);

// A shipped procedure with the model its table in docs/procedures.md pairs it with and the quirks
// its twin log has (paths relative to the source tree).
struct ShippedTwin {
  std::string name;       // "six_faces"
  std::string procedure;  // "configs/procedures/six_faces.yaml"
  std::string model;      // "estimators/ceres_nonlinear/examples/six_positions.yaml"
  std::vector<Quirk> quirks;
};
const std::vector<ShippedTwin>& shipped_twins();

}  // namespace stend::sim
