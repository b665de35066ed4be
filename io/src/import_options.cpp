// Import options: the key table, the parsing of each key's text, the YAML mapping file. See
// stend/io/import_options.hpp.
#include <stend/io/import_options.hpp>

#include <stend/errors.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/yaml/reader.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace stend::io {

namespace {

std::string trimmed(std::string s) {
  const auto a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return {};
  return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}

[[noreturn]] void bad(const std::string& key, const std::string& value, const std::string& expected) {
  throw std::invalid_argument(key + ": '" + excerpt(value) + "' is not " + expected);
}

double number(const std::string& key, const std::string& text) {
  const std::string s = trimmed(text);
  double v = 0.0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) bad(key, text, "a number");
  return v;
}

bool boolean(const std::string& key, const std::string& text) {
  const std::string s = trimmed(text);
  if (s == "true" || s == "yes" || s == "1") return true;
  if (s == "false" || s == "no" || s == "0") return false;
  bad(key, text, "true or false");
}

// A column by 0-based index (all digits) or by name.
CsvColumn column(const std::string& text) {
  const std::string s = trimmed(text);
  if (!s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return CsvColumn(std::stoi(s));
  return CsvColumn(s);
}

std::array<CsvColumn, 3> three_columns(const std::string& key, const std::string& text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= text.size(); ++i)
    if (i == text.size() || text[i] == ',') {
      parts.push_back(trimmed(text.substr(start, i - start)));
      start = i + 1;
    }
  if ((parts.size() != 3 && parts.size() != 1) ||
      std::any_of(parts.begin(), parts.end(), [](const std::string& p) { return p.empty(); }))
    bad(key, text, "three columns x,y,z (names or 0-based indices), or one array's name (N x 3, or N x 4 [t x y z])");
  if (parts.size() == 1) return {column(parts[0]), CsvColumn(), CsvColumn()};
  return {column(parts[0]), column(parts[1]), column(parts[2])};
}

// SI per unit: g and m/s^2 for the accelerometer, deg/s and rad/s for the gyroscope.
double unit_si(const std::string& key, const std::string& unit, bool accel) {
  const std::string u = trimmed(unit);
  if (accel && u == "g") return physics::kStandardGravity;
  if (accel && (u == "m/s^2" || u == "m/s2" || u == "mps2")) return 1.0;
  if (!accel && (u == "deg/s" || u == "dps")) return physics::kDegPerSecond;
  if (!accel && (u == "rad/s" || u == "radps")) return 1.0;
  bad(key, unit, accel ? "a unit g | m/s^2" : "a unit deg/s | rad/s");
}

// "1/16384 g", "1/16384g", "0.000598 m/s^2" → SI per count.
double lsb_si(const std::string& key, const std::string& text, bool accel) {
  const std::string s = trimmed(text);
  const auto unit_at = s.find_first_not_of("0123456789.eE+-/ ");
  if (unit_at == std::string::npos) bad(key, text, "NUMBER[/NUMBER] UNIT (e.g. 1/16384 g, 1/131 deg/s)");
  const std::string value = trimmed(s.substr(0, unit_at));
  const auto slash = value.find('/');
  const double v = slash == std::string::npos ? number(key, value)
                                              : number(key, value.substr(0, slash)) / number(key, value.substr(slash + 1));
  if (!(v > 0.0) || !std::isfinite(v)) bad(key, text, "a positive, finite count size");
  return v * unit_si(key, s.substr(unit_at), accel);
}

double time_unit(const std::string& key, const std::string& text) {
  const std::string u = trimmed(text);
  if (u == "s") return 1.0;
  if (u == "ms") return 1e-3;
  if (u == "us") return 1e-6;
  if (u == "ns") return 1e-9;
  bad(key, text, "a time unit s | ms | us | ns");
}

char delimiter(const std::string& key, const std::string& text) {
  if (text == "space" || text == " ") return ' ';
  if (text == "tab" || text == "\t") return '\t';
  if (text.size() == 1) return text[0];
  bad(key, text, "one character, space or tab");
}

// A count of something (lines, bytes): a whole number >= 0.
std::size_t count(const std::string& key, const std::string& text, const std::string& of) {
  const double n = number(key, text);
  if (n < 0 || n != std::floor(n) || n > 9.0e15) bad(key, text, "a count of " + of);
  return static_cast<std::size_t>(n);
}

// One record field's type: i8 u8 i16 u16 i32 u32 i64 u64 (bits), f32 f64.
RecordField field_type(const std::string& key, const std::string& name, const std::string& type) {
  RecordField f{name};
  const std::string bits = type.size() > 1 ? type.substr(1) : "";
  f.kind = type.empty() ? '?' : type[0];
  f.bytes = bits == "8" ? 1 : bits == "16" ? 2 : bits == "32" ? 4 : bits == "64" ? 8 : 0;
  const bool known = f.bytes > 0 && (f.kind == 'i' || f.kind == 'u' || (f.kind == 'f' && f.bytes >= 4));
  if (!known)
    throw std::invalid_argument(key + ": field '" + name + "' has type '" + excerpt(type) +
                                "', not one of i8 u8 i16 u16 i32 u32 i64 u64 f32 f64");
  return f;
}

// A field name: a letter or '_' first, then letters, digits and '_' (no ',' ':' '.', never all
// digits, which would be read as a column index).
bool field_name(const std::string& s) {
  const auto word = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
  return !s.empty() && word(s[0]) && std::all_of(s.begin(), s.end(), [&](char c) { return word(c) || (c >= '0' && c <= '9'); });
}

// "t:f64,ax:i16,_:u8" → the record's fields in order; "_" is padding (and may repeat), every other
// name is given once; at least one field is not padding.
std::vector<RecordField> record_layout(const std::string& key, const std::string& text) {
  constexpr std::size_t kMaxFields = 1024;
  std::vector<RecordField> fields;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= text.size(); ++i) {
    if (i < text.size() && text[i] != ',') continue;
    const std::string part = trimmed(text.substr(start, i - start));
    start = i + 1;
    const auto colon = part.find(':');
    if (colon == std::string::npos) bad(key, text, "NAME:TYPE fields separated by commas (e.g. t:f64,ax:i16,_:u8)");
    const std::string name = trimmed(part.substr(0, colon));
    if (!field_name(name))
      throw std::invalid_argument(key + ": '" + excerpt(name) +
                                  "' is not a field name (a letter or '_', then letters, digits or '_')");
    if (name != "_" && std::any_of(fields.begin(), fields.end(), [&](const RecordField& f) { return f.name == name; }))
      throw std::invalid_argument(key + ": field '" + name + "' is named twice");
    fields.push_back(field_type(key, name, trimmed(part.substr(colon + 1))));
    if (fields.size() > kMaxFields) bad(key, text, "a record of at most " + std::to_string(kMaxFields) + " fields");
  }
  if (std::all_of(fields.begin(), fields.end(), [](const RecordField& f) { return f.padding(); }))
    bad(key, text, "a record with a field that is not padding ('_')");
  return fields;
}

using Setter = void (*)(ImportOptions&, const std::string& key, const std::string& value);

// A key: its description, and how its text (parsed and checked as its type says) sets the options.
struct KeyDef {
  ImportKey info;
  Setter set;
};

using T = ImportKeyType;

// Every import key, declared once: the flags, the mapping file and the defaults all come from here.
const std::vector<KeyDef>& key_table() {
  static const std::vector<KeyDef> table = {
      {{"delimiter", T::kCharacter, "", ",", "column delimiter: one character, space (runs of blanks) or tab"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.delimiter = delimiter(k, v); }},
      {{"skip_lines", T::kCount, "lines", "0", "lines before the column-name line or the data"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.skip_lines = count(k, v, "lines"); }},
      {{"column_names", T::kBoolean, "", "true", "the first line names the columns: true | false"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.column_names = boolean(k, v); }},
      {{"comment", T::kText, "", "#", "data lines starting with this are ignored (\"\": none)"},
       [](ImportOptions& o, const std::string&, const std::string& v) { o.comment = v; }},
      {{"time", T::kColumn, "", "", "time column: name or 0-based index (absent: t = i / rate_hz)"},
       [](ImportOptions& o, const std::string&, const std::string& v) { o.time = column(v); }},
      {{"time_unit", T::kUnit, "", "s", "unit of the time column: s | ms | us | ns"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.time_scale_s = time_unit(k, v); }},
      {{"rate_hz", T::kNumber, "Hz", "",
        "sample rate: required without a time column; with one, the rate bad timestamps are rebuilt from"},
       [](ImportOptions& o, const std::string& k, const std::string& v) {
         o.rate_hz = number(k, v);
         if (!(o.rate_hz > 0.0)) bad(k, v, "a positive rate");
       }},
      {{"accel", T::kColumns, "", "",
        "accelerometer columns x,y,z (names or 0-based indices; in .mat/.npz/records: variables, 'struct.field', "
        "'array:K'), or one N x 3 / N x 4 [t x y z] array's name (absent: no accelerometer, a gyro-only log)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.accel = three_columns(k, v); }},
      {{"gyro", T::kColumns, "", "", "gyroscope columns x,y,z, or one array's name, as for accel (absent: no gyroscope)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.gyro = three_columns(k, v); }},
      {{"temperature", T::kColumn, "", "", "temperature column: name or 0-based index"},
       [](ImportOptions& o, const std::string&, const std::string& v) { o.temperature = column(v); }},
      {{"accel_unit", T::kUnit, "", "m/s^2", "accelerometer values in physical units: m/s^2 | g"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.accel_value.unit = unit_si(k, v, true); }},
      {{"gyro_unit", T::kUnit, "", "rad/s", "gyroscope values in physical units: rad/s | deg/s"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.gyro_value.unit = unit_si(k, v, false); }},
      {{"accel_lsb", T::kLsb, "", "", "accelerometer values are counts of this size: NUMBER[/NUMBER] g|m/s^2 (e.g. 1/16384g)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.accel_value.lsb = lsb_si(k, v, true); }},
      {{"accel_offset", T::kNumber, "counts", "0", "accelerometer count offset: SI = (count - offset) * lsb (e.g. 32768)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.accel_value.offset = number(k, v); }},
      {{"gyro_lsb", T::kLsb, "", "", "gyroscope values are counts of this size: NUMBER[/NUMBER] deg/s|rad/s (e.g. 1/131deg/s)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.gyro_value.lsb = lsb_si(k, v, false); }},
      {{"gyro_offset", T::kNumber, "counts", "0", "gyroscope count offset"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.gyro_value.offset = number(k, v); }},
      {{"temperature_scale", T::kNumber, "degC per unit", "1", "the temperature column's scale"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.temperature_scale = number(k, v); }},
      {{"temperature_offset_c", T::kNumber, "degC", "0", "added to the temperature after scaling"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.temperature_offset_c = number(k, v); }},
      {{"gravity_mps2", T::kNumber, "m/s^2", "0", "local gravity (0: unknown, standard gravity where one is needed)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) {
         o.gravity_mps2 = number(k, v);
         if (o.gravity_mps2 != 0.0 &&
             (o.gravity_mps2 < physics::kMinPlausibleGravity_mps2 || o.gravity_mps2 > physics::kMaxPlausibleGravity_mps2))
           bad(k, v,
               "a gravity in " + yaml::format_number(physics::kMinPlausibleGravity_mps2) + " … " +
                   yaml::format_number(physics::kMaxPlausibleGravity_mps2) + " m/s^2 (or 0)");
       }},
      {{"topic", T::kText, "", "", "ROS bags: the sensor_msgs Imu topic (absent: the bag's only Imu topic)"},
       [](ImportOptions& o, const std::string&, const std::string& v) { o.topic = v; }},
      {{"temperature_topic", T::kText, "", "", "ROS bags: a sensor_msgs Temperature topic to take the temperature from"},
       [](ImportOptions& o, const std::string&, const std::string& v) { o.temperature_topic = v; }},
      {{"instance", T::kCount, "", "", "ULog / DataFlash: the IMU instance (absent: the instance with the most samples)"},
       [](ImportOptions& o, const std::string& k, const std::string& v) {
         const double n = number(k, v);
         if (n < 0 || n != std::floor(n) || n > 255) bad(k, v, "an instance number 0 … 255");
         o.instance = static_cast<int>(n);
       }},
      {{"record_layout", T::kText, "", "",
        "raw binary records: their fields in order, NAME:TYPE separated by commas (e.g. t:f64,ax:i16,ay:i16,az:i16,_:u16); "
        "types i8 u8 i16 u16 i32 u32 i64 u64 f32 f64, '_' a padding field; each field is an array named by its name"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.record_layout = record_layout(k, v); }},
      {{"byte_order", T::kText, "", "little", "raw records' byte order: little | big"},
       [](ImportOptions& o, const std::string& k, const std::string& v) {
         const std::string s = trimmed(v);
         if (s != "little" && s != "big") bad(k, v, "little or big");
         o.big_endian = s == "big";
       }},
      {{"header_bytes", T::kCount, "bytes", "0", "raw records: bytes before the first record"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.header_bytes = count(k, v, "bytes"); }},
      {{"drop_bad_samples", T::kSwitch, "", "false",
        "drop samples whose time or values are not finite numbers (or whose time goes back), and count them, "
        "instead of refusing the log"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.drop_bad_samples = boolean(k, v); }},
      {{"accept_implausible", T::kSwitch, "", "false",
        "import a log whose stillest stretch reads |a| far from 1 g or a rate beyond any MEMS gyroscope "
        "(a centrifuge) as it is, instead of refusing it as wrong units"},
       [](ImportOptions& o, const std::string& k, const std::string& v) { o.accept_implausible = boolean(k, v); }},
  };
  return table;
}

const KeyDef& key_def(const std::string& key) {
  const auto& table = key_table();
  const auto it = std::find_if(table.begin(), table.end(), [&](const KeyDef& d) { return d.info.key == key; });
  if (it == table.end()) throw std::invalid_argument("unknown import key '" + key + "'");
  return *it;
}

}  // namespace

const char* ImportKey::type_name() const {
  switch (type) {
    case ImportKeyType::kText: return "TEXT";
    case ImportKeyType::kCharacter: return "CHAR";
    case ImportKeyType::kCount: return "COUNT";
    case ImportKeyType::kBoolean: return "BOOL";
    case ImportKeyType::kSwitch: return "BOOL";
    case ImportKeyType::kNumber: return "NUMBER";
    case ImportKeyType::kColumn: return "COLUMN";
    case ImportKeyType::kColumns: return "X,Y,Z";
    case ImportKeyType::kUnit: return "UNIT";
    case ImportKeyType::kLsb: return "LSB";
  }
  return "TEXT";
}

std::string ImportKey::description() const {
  return help + (unit.empty() ? "" : ", in " + unit) + (fallback.empty() ? "" : " [" + fallback + "]");
}

const std::vector<ImportKey>& import_keys() {
  static const std::vector<ImportKey> keys = [] {
    std::vector<ImportKey> out;
    for (const auto& d : key_table()) out.push_back(d.info);
    return out;
  }();
  return keys;
}

std::string import_flag(const std::string& key) {
  std::string f = "--" + key;
  std::replace(f.begin(), f.end(), '_', '-');
  return f;
}

ImportOptions::ImportOptions() {
  for (const auto& d : key_table())
    if (!d.info.fallback.empty()) d.set(*this, d.info.key, d.info.fallback);
}

void ImportOptions::set(const std::string& key, const std::string& value) {
  key_def(key).set(*this, key, value);
  stated.push_back(key + ": " + value);
}

bool ImportOptions::was_stated(const std::string& key) const {
  return std::any_of(stated.begin(), stated.end(), [&](const std::string& s) { return s.rfind(key + ": ", 0) == 0; });
}

namespace {

// How many of a triad's x, y, z columns are given.
int mapped(const std::array<CsvColumn, 3>& triad) {
  return static_cast<int>(std::count_if(triad.begin(), triad.end(), [](const CsvColumn& c) { return !c.empty(); }));
}

// A triad is given whole (x, y, z), as one array's name (x alone), or not at all.
bool triad_given(const std::array<CsvColumn, 3>& triad) {
  const int n = mapped(triad);
  return n == 0 || n == 3 || (n == 1 && !triad[0].empty());
}

}  // namespace

bool ImportOptions::maps_columns() const { return mapped(accel) > 0 || mapped(gyro) > 0; }

bool ImportOptions::IsValid(std::string* error) const {
  const auto fail = [error](const std::string& why) { return invalid(error, why); };
  if (!triad_given(accel)) return fail("accel: give x, y and z columns, one array's name, or none");
  if (!triad_given(gyro)) return fail("gyro: give x, y and z columns, one array's name, or none");
  if (!maps_columns() && (!time.empty() || !temperature.empty()))
    return fail("accel, gyro: columns are mapped (time or temperature given) but no instrument's: give --accel x,y,z, "
                "--gyro x,y,z or both");
  if (!(time_scale_s > 0.0)) return fail("time_unit: must be positive");
  if (accel_value.offset != 0.0 && !accel_value.counts()) return fail("accel_offset: needs accel_lsb (the values are counts)");
  if (gyro_value.offset != 0.0 && !gyro_value.counts()) return fail("gyro_offset: needs gyro_lsb (the values are counts)");
  for (const char* key : {"byte_order", "header_bytes"})
    if (record_layout.empty() && was_stated(key)) return fail(std::string(key) + ": needs record_layout (raw records)");
  return true;
}

CsvMapping ImportOptions::csv_mapping() const {
  CsvMapping m;
  m.delimiter = delimiter;
  m.skip_lines = skip_lines;
  m.column_names = column_names;
  m.comment_prefix = comment;
  m.time = time;
  m.time_scale_s = time_scale_s;
  m.rate_hz = rate_hz;
  m.accel = accel;
  m.gyro = gyro;
  m.temperature = temperature;
  m.accel_counts = accel_value.counts();
  m.gyro_counts = gyro_value.counts();
  m.accel_scale = m.accel_counts ? accel_value.lsb : accel_value.unit;
  m.accel_offset_counts = accel_value.offset;
  m.gyro_scale = gyro_value.counts() ? gyro_value.lsb : gyro_value.unit;
  m.gyro_offset_counts = gyro_value.offset;
  m.temperature_counts = false;  // temperature_scale/offset_c convert whatever the column holds
  m.temperature_scale = temperature_scale;
  m.temperature_offset_c = temperature_offset_c;
  m.gravity_mps2 = gravity_mps2;
  m.drop_bad_samples = drop_bad_samples;
  return m;
}

void read_import_mapping(const std::filesystem::path& file, ImportOptions& options) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::BadFile&) {
    throw ExperimentError({file.string(), 0, 0}, "", "cannot open the mapping file (check the path)");
  } catch (const YAML::ParserException& e) {
    throw ExperimentError({file.string(), e.mark.line + 1, e.mark.column + 1}, "", e.msg);
  }
  std::vector<std::string> keys;
  for (const auto& k : import_keys()) keys.push_back(k.key);
  const yaml::MapReader m(root, file.string(), "", "import mapping", keys);
  for (const std::string& key : m.keys()) {
    const YAML::Node v = m.get(key);
    std::string text;
    if (v.IsSequence()) {
      for (std::size_t i = 0; i < v.size(); ++i)
        text += (i ? "," : "") + yaml::as_string(v[i], file.string(), key + "[" + std::to_string(i) + "]");
    } else {
      text = yaml::as_string(v, file.string(), key);
    }
    try {
      options.set(key, text);
    } catch (const std::invalid_argument& e) {
      m.fail_value(key, e.what());
    }
  }
}

}  // namespace stend::io
