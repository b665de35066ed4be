// The twin's quirky logs. See stend/sim/twin_log.hpp.
#include <stend/sim/twin_log.hpp>

#include <stend/physics/units.hpp>

#include <fmt/format.h>

#include <fstream>
#include <stdexcept>

namespace stend::sim {

namespace {

constexpr Quirk kAllQuirks[] = {Quirk::kNoTime, Quirk::kLowRate, Quirk::kBursty, Quirk::kCounts, Quirk::kShort};

bool has(const std::vector<Quirk>& quirks, Quirk q) {
  for (Quirk x : quirks)
    if (x == q) return true;
  return false;
}

// A number with `digits` significant digits, or `digits` decimals with fixed.
std::string number(double v, int digits, bool fixed = false) {
  return fixed ? fmt::format("{:.{}f}", v, digits) : fmt::format("{:.{}g}", v, digits);
}

// The logged time of sample k: its true time, or with bursts the time its burst arrived plus its
// place in the burst (a burst arrives when its last sample is due).
double logged_time(const Played& p, std::size_t k, const CsvQuirks& q) {
  if (!q.bursty) return p.samples[k].t_s;
  const auto size = static_cast<std::size_t>(q.burst_size);
  const std::size_t last = std::min(p.samples.size() - 1, (k / size) * size + size - 1);
  return p.samples[last].t_s + static_cast<double>(k % size) * q.burst_spacing_s;
}

std::string header(const CsvQuirks& q) {
  std::string h = q.no_time ? "" : "t_s,";
  h += q.counts ? "ax,ay,az,gx,gy,gz" : "ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps";
  return h + ",temperature_c\n";
}

std::string line(const Played& p, std::size_t k, const CsvQuirks& q) {
  const ImuSample& s = p.samples[k];
  std::string out = q.no_time ? "" : number(logged_time(p, k, q), 6, true) + ",";
  for (int i = 0; i < 3; ++i)
    out += q.counts ? std::to_string(s.accel_counts[i]) + "," : number(s.accel_mps2[i], 9) + ",";
  for (int i = 0; i < 3; ++i)
    out += q.counts ? std::to_string(s.gyro_counts[i]) + "," : number(s.gyro_radps[i], 9) + ",";
  return out + number(s.temperature_c, 3, true) + "\n";
}

}  // namespace

const char* quirk_name(Quirk q) {
  switch (q) {
    case Quirk::kNoTime: return "no_time";
    case Quirk::kLowRate: return "low_rate";
    case Quirk::kBursty: return "bursty";
    case Quirk::kCounts: return "counts";
    case Quirk::kShort: return "short";
  }
  return "?";
}

Quirk quirk_from_name(const std::string& name) {
  std::string names;
  for (Quirk q : kAllQuirks) {
    if (name == quirk_name(q)) return q;
    names += std::string(names.empty() ? "" : ", ") + quirk_name(q);
  }
  throw std::invalid_argument("unknown quirk '" + name + "' (one of: " + names + ")");
}

std::string quirk_list(const std::vector<Quirk>& quirks) {
  std::string out;
  for (Quirk q : quirks) out += std::string(out.empty() ? "" : ", ") + quirk_name(q);
  return out.empty() ? "none" : out;
}

TwinSetup twin_setup(const std::vector<Quirk>& quirks, std::uint64_t seed) {
  TwinSetup t;
  t.player.seed = seed;
  t.sensor = twin_sensor(seed);
  if (has(quirks, Quirk::kLowRate)) {
    t.player.rate_hz = 16.0;
    t.sensor.lowpass_hz = 5.0;  // the MPU-6050's digital low-pass at 5 Hz (DLPF_CFG 6)
  }
  if (has(quirks, Quirk::kShort)) {
    t.player.hand.hold_s = 1.5;
    t.player.hand.hold_factor = 0.7;
  }
  t.csv.no_time = has(quirks, Quirk::kNoTime);
  t.csv.counts = has(quirks, Quirk::kCounts);
  t.csv.bursty = has(quirks, Quirk::kBursty);
  return t;
}

ImportKeys twin_import_keys(const CsvQuirks& q, const Played& p) {
  ImportKeys k;
  if (q.no_time)
    k.emplace_back("rate_hz", number(p.info.output_rate_hz, 10));
  else
    k.emplace_back("time", "t_s");
  k.emplace_back("accel", q.counts ? "ax,ay,az" : "ax_mps2,ay_mps2,az_mps2");
  k.emplace_back("gyro", q.counts ? "gx,gy,gz" : "gx_radps,gy_radps,gz_radps");
  k.emplace_back("temperature", "temperature_c");
  if (q.counts) {
    k.emplace_back("accel_lsb", "1/" + number(physics::kStandardGravity / p.info.accel_lsb_mps2, 10) + "g");
    k.emplace_back("gyro_lsb", "1/" + number(physics::kDegPerSecond / p.info.gyro_lsb_radps, 10) + "deg/s");
  }
  return k;
}

std::string import_flags(const ImportKeys& keys) {
  std::string out;
  for (const auto& [key, value] : keys) {
    std::string flag = "--" + key;
    for (char& c : flag)
      if (c == '_') c = '-';
    out += " " + flag + " " + value;
  }
  return out;
}

ImportKeys write_twin_csv(const std::filesystem::path& file, const Played& played, const CsvQuirks& csv) {
  if (csv.bursty && !(csv.burst_size >= 2 && csv.burst_spacing_s > 0.0))
    throw std::invalid_argument("twin log: bursts need burst_size >= 2 and burst_spacing_s > 0");
  std::ofstream out(file);
  if (!out) throw std::runtime_error("twin log: cannot write " + file.string());
  out << header(csv);
  for (std::size_t k = 0; k < played.samples.size(); ++k) out << line(played, k, csv);
  out.close();
  if (!out) throw std::runtime_error("twin log: write failed: " + file.string());
  return twin_import_keys(csv, played);
}

const std::vector<ShippedTwin>& shipped_twins() {
  static const std::vector<ShippedTwin> table = [] {
    const std::string procedures = "configs/procedures/", models = "estimators/ceres_nonlinear/examples/";
    const auto twin = [&](const char* name, const char* model, std::vector<Quirk> quirks) {
      return ShippedTwin{name, procedures + name + ".yaml", models + model + ".yaml", std::move(quirks)};
    };
    return std::vector<ShippedTwin>{
        twin("six_faces", "six_positions", {Quirk::kCounts, Quirk::kNoTime}),
        twin("tumble_12", "six_positions", {Quirk::kLowRate}),
        twin("tumble_24", "six_positions", {Quirk::kShort}),
        twin("ferraris", "ferraris", {Quirk::kCounts, Quirk::kNoTime}),
        twin("rate_legs", "rate_legs", {Quirk::kLowRate, Quirk::kShort}),
        twin("up_down_earth_rate", "earth_rate", {Quirk::kCounts}),
        twin("unknown_orientations", "unknown_orientations", {Quirk::kShort, Quirk::kNoTime}),
    };
  }();
  return table;
}

}  // namespace stend::sim
