// Raw binary records read through a stated layout (io/src/records_file.cpp, issue 42): the
// record_layout, byte_order and header_bytes keys, every field type in both byte orders read back
// value by value, a last record cut short dropped and reported, the format chosen by the layout,
// and `stend import` of a logger's records.
#include <gtest/gtest.h>

#include <stend/io/formats.hpp>
#include <stend/io/import_options.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/samples.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/program.hpp>

#include "arrays.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

// The message of the std::invalid_argument `set` throws for key = value.
std::string refusal(const std::string& key, const std::string& value) {
  try {
    ImportOptions().set(key, value);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "accepted";
}

// Every type, padding between fields, and a name of each kind.
const char* kLayout = "t:f64,gx:f32,gy:f32,gz:f32,ax:i16,ay:i16,az:i16,_:u16,temp:u8,_:u8,seq:u32,big:i64,ubig:u64,sb:i8,n:u16,w:i32";
constexpr std::size_t kRecordBytes = 8 + 3 * 4 + 3 * 2 + 2 + 1 + 1 + 4 + 8 + 8 + 1 + 2 + 4;

// The value of field `name` in record i: different for each, exact in the field's type.
double value(const std::string& name, std::size_t i) {
  const auto k = static_cast<double>(i);
  if (name == "t") return k * 0.01;
  if (name == "gx") return (std::fmod(k, 13) - 6) / 1024;
  if (name == "gy") return (std::fmod(k, 17) - 8) / 2048;
  if (name == "gz") return (std::fmod(k, 19) - 9) / 4096;
  if (name == "ax") return std::fmod(k, 7) - 3;
  if (name == "ay") return 40 - std::fmod(k, 11);
  if (name == "az") return 16384 + std::fmod(k, 5);
  if (name == "temp") return std::fmod(k, 256);
  if (name == "seq") return 4000000000.0 - k;
  if (name == "big") return -0x1p50 + k * 3;
  if (name == "ubig") return 0x1p60 + k * 4096;
  if (name == "sb") return std::fmod(k, 256) - 128;
  if (name == "n") return 65535 - k;
  return -2000000000.0 + k * 7;  // w
}

// The bytes of v as type T in the byte order asked for.
template <class T>
void put(std::string& out, double v, bool big) {
  const T x = static_cast<T>(v);
  char b[sizeof(T)];
  std::memcpy(b, &x, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// `header` bytes, then n records of kLayout (padding bytes 0xEE).
std::string records(std::size_t n, bool big, std::size_t header) {
  std::string out(header, 'H');
  for (std::size_t i = 0; i < n; ++i) {
    put<double>(out, value("t", i), big);
    for (const char* g : {"gx", "gy", "gz"}) put<float>(out, value(g, i), big);
    for (const char* a : {"ax", "ay", "az"}) put<std::int16_t>(out, value(a, i), big);
    out += "\xEE\xEE";
    put<std::uint8_t>(out, value("temp", i), big);
    out += "\xEE";
    put<std::uint32_t>(out, value("seq", i), big);
    put<std::int64_t>(out, value("big", i), big);
    put<std::uint64_t>(out, value("ubig", i), big);
    put<std::int8_t>(out, value("sb", i), big);
    put<std::uint16_t>(out, value("n", i), big);
    put<std::int32_t>(out, value("w", i), big);
  }
  return out;
}

ImportOptions layout_options(bool big, std::size_t header) {
  ImportOptions o;
  o.set("record_layout", kLayout);
  o.set("byte_order", big ? "big" : "little");
  o.set("header_bytes", std::to_string(header));
  return o;
}

}  // namespace

TEST(RecordLayout, IsParsedAndCheckedWhereTheKeyIsSet) {
  ImportOptions o;
  o.set("record_layout", " t : f64 , ax:i16,_:u8,_:u8 ,Temp_2:u8");
  ASSERT_EQ(o.record_layout.size(), 5u);
  EXPECT_EQ(o.record_layout[0].name, "t");
  EXPECT_EQ(o.record_layout[0].kind, 'f');
  EXPECT_EQ(o.record_layout[0].bytes, 8u);
  EXPECT_EQ(o.record_layout[1].kind, 'i');
  EXPECT_EQ(o.record_layout[1].bytes, 2u);
  EXPECT_TRUE(o.record_layout[2].padding());
  EXPECT_EQ(o.record_layout[4].name, "Temp_2");
  EXPECT_FALSE(o.big_endian);
  EXPECT_EQ(o.header_bytes, 0u);

  EXPECT_EQ(refusal("record_layout", "t:f64,ax"),
            "record_layout: 't:f64,ax' is not NAME:TYPE fields separated by commas (e.g. t:f64,ax:i16,_:u8)");
  EXPECT_EQ(refusal("record_layout", "t:f16"), "record_layout: field 't' has type 'f16', not one of i8 u8 i16 u16 i32 u32 i64 u64 f32 f64");
  EXPECT_EQ(refusal("record_layout", "t:int16"), "record_layout: field 't' has type 'int16', not one of i8 u8 i16 u16 i32 u32 i64 u64 f32 f64");
  EXPECT_EQ(refusal("record_layout", "t:f64,t:i16"), "record_layout: field 't' is named twice");
  EXPECT_EQ(refusal("record_layout", "4:f64"), "record_layout: '4' is not a field name (a letter or '_', then letters, digits or '_')");
  EXPECT_EQ(refusal("record_layout", "a.b:f64"), "record_layout: 'a.b' is not a field name (a letter or '_', then letters, digits or '_')");
  EXPECT_EQ(refusal("record_layout", "_:u8,_:u16"), "record_layout: '_:u8,_:u16' is not a record with a field that is not padding ('_')");
  EXPECT_EQ(refusal("byte_order", "middle"), "byte_order: 'middle' is not little or big");
  EXPECT_EQ(refusal("header_bytes", "-4"), "header_bytes: '-4' is not a count of bytes");

  ImportOptions alone;
  alone.set("byte_order", "big");
  std::string why;
  EXPECT_FALSE(alone.IsValid(&why));
  EXPECT_EQ(why, "byte_order: needs record_layout (raw records)");
}

TEST(Records, EveryFieldTypeRoundTripsExactlyInBothByteOrders) {
  TempDir dir("records");
  const std::size_t n = 5000;  // several read blocks
  for (const bool big : {false, true}) {
    SCOPED_TRACE(big ? "big-endian" : "little-endian");
    write_text(dir / "log.bin", records(n, big, 17));
    const auto f = io::detail::open_records(dir / "log.bin", layout_options(big, 17));
    EXPECT_EQ(f->damage(), "");
    EXPECT_EQ(f->layout(), "raw records of " + std::to_string(kRecordBytes) + " bytes (14 fields, " +
                               (big ? "big" : "little") + "-endian) after a 17-byte header, 5000 records");
    const std::vector<std::pair<std::string, std::string>> fields = {
        {"t", "float64"}, {"gx", "float32"}, {"gy", "float32"}, {"gz", "float32"}, {"ax", "int16"}, {"ay", "int16"},
        {"az", "int16"}, {"temp", "uint8"}, {"seq", "uint32"}, {"big", "int64"}, {"ubig", "uint64"}, {"sb", "int8"},
        {"n", "uint16"}, {"w", "int32"}};
    const auto arrays = f->arrays();
    ASSERT_EQ(arrays.size(), fields.size());
    for (std::size_t k = 0; k < fields.size(); ++k) {
      EXPECT_EQ(arrays[k].name, fields[k].first);
      EXPECT_EQ(arrays[k].rows, n);
      EXPECT_EQ(arrays[k].cols, 1u);
      const bool one_byte = fields[k].second == "int8" || fields[k].second == "uint8";  // no byte order
      EXPECT_EQ(arrays[k].type, fields[k].second + (big && !one_byte ? " big-endian" : "")) << fields[k].first;
      auto s = f->open(fields[k].first);
      std::vector<double> v(n);
      for (std::size_t at = 0; at < n;) {
        const std::size_t step = std::min<std::size_t>(1234, n - at);
        s->read(step, v.data() + at);
        at += step;
      }
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (v[i] != value(fields[k].first, i) && wrong++ == 0)
          ADD_FAILURE() << fields[k].first << "[" << i << "] = " << v[i] << ", written " << value(fields[k].first, i);
      EXPECT_EQ(wrong, 0u) << fields[k].first;
    }
    EXPECT_THROW(f->open("_"), ImportError);
  }
}

TEST(Records, ALastRecordCutShortIsDroppedAndReported) {
  TempDir dir("records-cut");
  write_text(dir / "log.bin", records(100, false, 3) + records(1, false, 0).substr(0, 11));
  const auto f = io::detail::open_records(dir / "log.bin", layout_options(false, 3));
  EXPECT_EQ(f->damage(), "the last record is cut after 11 of " + std::to_string(kRecordBytes) + " bytes at byte offset " +
                             std::to_string(3 + 100 * kRecordBytes) + "; 100 whole records kept");
  ASSERT_EQ(f->arrays().at(0).rows, 100u);
  auto t = f->open("t");
  std::vector<double> v(100);
  t->read(100, v.data());
  EXPECT_EQ(v[99], value("t", 99));
}

TEST(Records, AHeaderBeyondTheFileIsRefusedWithItsOffset) {
  TempDir dir("records-header");
  write_text(dir / "log.bin", std::string(40, 'x'));
  try {
    io::detail::open_records(dir / "log.bin", layout_options(false, 64));
    FAIL() << "accepted";
  } catch (const ImportError& e) {
    EXPECT_EQ(e.offset().value_or(0), 40u);
    EXPECT_NE(std::string(e.what()).find("header_bytes is 64, the file holds 40"), std::string::npos) << e.what();
  }
}

// --- through the format table and `stend import` -------------------------------------------------

namespace {

const char* kImportArgs = " --time t --accel ax,ay,az --accel-lsb 1/16384g --gyro gx,gy,gz --gyro-unit rad/s";

void expect_samples(const Recording& rec, std::size_t n) {
  std::size_t i = 0, wrong = 0;
  const double lsb = physics::kStandardGravity / 16384;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* s, std::size_t count, std::uint64_t) {
    for (std::size_t k = 0; k < count; ++k, ++i) {
      bool ok = std::abs(s[k].t_s - value("t", i)) < 1e-9;
      const char* acc[] = {"ax", "ay", "az"};
      const char* gyr[] = {"gx", "gy", "gz"};
      for (int c = 0; c < 3; ++c)
        ok = ok && s[k].accel_counts[c] == value(acc[c], i) && s[k].accel_mps2[c] == value(acc[c], i) * lsb &&
             s[k].gyro_radps[c] == value(gyr[c], i);
      if (!ok && wrong++ == 0) ADD_FAILURE() << "sample " << i << " differs from what was written";
    }
  });
  EXPECT_EQ(i, n);
  EXPECT_EQ(wrong, 0u);
}

}  // namespace

TEST(ImportRecords, TheLayoutChoosesTheFormatAndTheCutIsAWarning) {
  TempDir dir("records-import");
  write_text(dir / "log.bin", records(2000, true, 0) + "abc");
  ImportOptions o;
  for (const auto& [k, v] : std::vector<std::pair<const char*, const char*>>{
           {"record_layout", kLayout}, {"byte_order", "big"}, {"time", "t"}, {"accel", "ax,ay,az"},
           {"accel_lsb", "1/16384g"}, {"gyro", "gx,gy,gz"}, {"gyro_unit", "rad/s"}})
    o.set(k, v);
  EXPECT_EQ(detect_format({dir / "log.bin"}, o).name, "records");
  std::string used;
  const Recording rec = open_dataset({dir / "log.bin"}, "auto", o, &used);
  EXPECT_EQ(used, "records");
  expect_samples(rec, 2000);
  bool warned = false;
  for (const Event& e : rec.events)
    warned = warned || (e.level == "warning" && e.message == "log.bin: the last record is cut after 3 of " +
                                                                  std::to_string(kRecordBytes) + " bytes at byte offset " +
                                                                  std::to_string(2000 * kRecordBytes) + "; 2000 whole records kept");
  EXPECT_TRUE(warned);

  try {
    open_dataset({dir / "log.bin"}, "records", ImportOptions());
    FAIL() << "read without a layout";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("give record_layout (--record-layout"), std::string::npos) << e.what();
  }
}

TEST(ImportRecords, StendImportWorkedExample) {
  TempDir dir("records-cli");
  write_text(dir / "imu.bin", records(1500, false, 32) + "tail");
  const auto out = stend::testing::run_stend("import " + (dir / "imu.bin").string() + " --record-layout " + kLayout +
                                             " --header-bytes 32" + kImportArgs + " -o " + (dir / "run").string());
  ASSERT_EQ(out.code, 0) << out.text;
  EXPECT_NE(out.text.find("format:     records"), std::string::npos) << out.text;
  EXPECT_NE(out.text.find("imported 1500 samples (imu.bin: raw records of " + std::to_string(kRecordBytes) +
                          " bytes (14 fields, little-endian) after a 32-byte header, 1500 records): accel 'ax','ay','az'"),
            std::string::npos)
      << out.text;
  EXPECT_NE(out.text.find("the last record is cut after 4 of"), std::string::npos) << out.text;
  expect_samples(Recording::open(dir / "run", SampleLoading::kStream), 1500);
}
