// NumPy .npy and .npz files read as named arrays (io/src/npy_file.cpp, issue 42): every dtype,
// byte order, memory order and shape NumPy writes (np.save, np.savez, np.savez_compressed, zip64
// archives, format versions 1.0 to 3.0), written here by NumPy itself and read back value by
// value; damaged files refused at the byte where they are damaged; an .npz imported through the
// format table and through `stend import`.
#include <gtest/gtest.h>

#include <stend/io/formats.hpp>
#include <stend/io/import_options.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/samples.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/program.hpp>

#include "arrays.hpp"
#include "zip_archive.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::read_text;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

// Debian's python3 with python3-numpy (the interpreter NumPy is installed for), else python3.
std::string python() { return fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3"; }
bool have_numpy() { return stend::testing::run_command(python() + " -c 'import numpy' 2>&1").code == 0; }
#define SKIP_WITHOUT_NUMPY() \
  if (!have_numpy()) GTEST_SKIP() << "python3-numpy is not installed (scripts/install-deps.sh installs it): NumPy writes these files"

// Runs a Python script (written into `dir`) with `dir` as its argument.
void run_python(const fs::path& dir, const std::string& script) {
  write_text(dir / "write.py", script);
  const auto out = stend::testing::run_command(python() + " " + (dir / "write.py").string() + " " + dir.string() + " 2>&1");
  ASSERT_EQ(out.code, 0) << out.text;
}

// How an array of n samples × cols components is laid out in the file.
enum class Layout { kRows, kFortran, kCols, kColsFortran, kVector, kRow, kScalar };
const char* layout_word(Layout l) {
  switch (l) {
    case Layout::kRows: return "rows";
    case Layout::kFortran: return "fortran";
    case Layout::kCols: return "cols";
    case Layout::kColsFortran: return "cols_fortran";
    case Layout::kVector: return "vector";
    case Layout::kRow: return "row";
    case Layout::kScalar: return "scalar";
  }
  return "";
}

struct Spec {
  const char* name;
  const char* descr;  // NumPy's dtype text
  std::size_t n, cols;
  Layout layout;
  const char* type;   // ArrayInfo::type
};

// Every dtype Stend reads, both byte orders, C and Fortran order, N×C, C×N (read transposed),
// 1-D, 1×N, 0-D and empty: the arrays NumPy writes for the tests below.
const std::vector<Spec>& specs() {
  static const std::vector<Spec> s = {
      {"f8", "<f8", 10000, 3, Layout::kRows, "float64"},  // several read blocks
      {"f4_counts", "<f4", 1000, 3, Layout::kRows, "float32"},
      {"i2", "<i2", 1000, 3, Layout::kRows, "int16"},
      {"u2", "<u2", 1000, 3, Layout::kRows, "uint16"},
      {"i4", "<i4", 1000, 3, Layout::kRows, "int32"},
      {"u4", "<u4", 1000, 3, Layout::kRows, "uint32"},
      {"i8", "<i8", 1000, 3, Layout::kRows, "int64"},
      {"u8", "<u8", 1000, 3, Layout::kRows, "uint64"},
      {"i1", "|i1", 1000, 3, Layout::kRows, "int8"},
      {"u1", "|u1", 1000, 3, Layout::kRows, "uint8"},
      {"f8_be", ">f8", 1000, 3, Layout::kRows, "float64 big-endian"},
      {"f4_be", ">f4", 1000, 3, Layout::kRows, "float32 big-endian"},
      {"i2_be", ">i2", 1000, 3, Layout::kRows, "int16 big-endian"},
      {"u4_be", ">u4", 1000, 3, Layout::kRows, "uint32 big-endian"},
      {"i8_be", ">i8", 1000, 3, Layout::kRows, "int64 big-endian"},
      {"fortran", "<f8", 1000, 3, Layout::kFortran, "float64"},
      {"fortran_wide", "<i2", 3000, 7, Layout::kFortran, "int16"},
      {"acc_3xN", "<f8", 10000, 3, Layout::kCols, "float64"},
      {"buf_4xN_fortran", "<f4", 800, 4, Layout::kColsFortran, "float32"},
      {"vector", "<f4", 1000, 1, Layout::kVector, "float32"},
      {"row", "<f8", 600, 1, Layout::kRow, "float64"},
      {"scalar", "<f8", 1, 1, Layout::kScalar, "float64"},
      {"empty", "<i2", 0, 3, Layout::kRows, "int16"},
  };
  return s;
}

// Sample i, component c of an array of dtype `descr`: different for each, exact in the dtype,
// spanning its bytes (the same arithmetic as values() in the script below).
double expected(const std::string& descr, std::size_t i, std::size_t c) {
  const double b = static_cast<double>((i * 37 + c * 101) % 241);
  const char kind = descr[1];
  const int size = std::stoi(descr.substr(2));
  if (kind == 'f') return (b - 120) * 0.125;
  if (kind == 'i') return (b - 120) * (size == 1 ? 1 : size == 2 ? 200 : size == 4 ? 1e7 : 0x1p40);
  return b * (size == 1 ? 1 : size == 2 ? 200 : size == 4 ? 1e7 : 0x1p44);
}

// Writes every spec as NAME.npy (np.save), all of them with three arrays Stend does not read into
// stored.npz (np.savez) and deflated.npz (np.savez_compressed), the specs into zip64.npz (zip64
// records throughout), and f8 / acc_3xN as format versions 2.0 and 3.0.
void write_numpy_files(const fs::path& dir) {
  std::string table;
  for (const Spec& s : specs())
    table += std::string("    ('") + s.name + "', '" + s.descr + "', " + std::to_string(s.n) + ", " + std::to_string(s.cols) +
             ", '" + layout_word(s.layout) + "'),\n";
  run_python(dir, R"(import sys, zipfile, numpy as np
out = sys.argv[1]
specs = [
)" + table + R"(]
def values(descr, n, cols):
    i = np.arange(n, dtype=np.int64)[:, None]
    c = np.arange(cols, dtype=np.int64)[None, :]
    b = (i * 37 + c * 101) % 241
    kind, size = descr[1], int(descr[2:])
    if kind == 'f':
        v = (b - 120) * 0.125
    elif kind == 'i':
        v = (b - 120) * {1: 1, 2: 200, 4: 10**7, 8: 2**40}[size]
    else:
        v = b * {1: 1, 2: 200, 4: 10**7, 8: 2**44}[size]
    return v.astype(descr)
arrays = {}
for name, descr, n, cols, layout in specs:
    v = values(descr, n, cols)
    a = {'rows': lambda: np.ascontiguousarray(v), 'fortran': lambda: np.asfortranarray(v),
         'cols': lambda: np.ascontiguousarray(v.T), 'cols_fortran': lambda: np.asfortranarray(v.T),
         'vector': lambda: v[:, 0].copy(), 'row': lambda: np.ascontiguousarray(v.T),
         'scalar': lambda: np.array(v[0, 0])}[layout]()
    arrays[name] = a
    np.save(out + '/' + name + '.npy', a)
unread = {'labels': np.array(['a', 'bb']), 'cplx': np.arange(3) * 1j, 'cube': np.zeros((2, 3, 4))}
np.savez(out + '/stored.npz', **arrays, **unread)
np.savez_compressed(out + '/deflated.npz', **arrays, **unread)
with open(out + '/v2.npy', 'wb') as f:
    np.lib.format.write_array(f, arrays['f8'], version=(2, 0))
with open(out + '/v3.npy', 'wb') as f:
    np.lib.format.write_array(f, arrays['acc_3xN'], version=(3, 0))
zipfile.ZIP64_LIMIT = 1000  # every size and offset past it goes into zip64 records, as for arrays over 2 GB
np.savez_compressed(out + '/zip64.npz', **arrays)
)");
}

// The array `s` of `f` read in blocks of 777 rows: its shape, and every value as written.
void expect_values(const io::detail::ArrayFile& f, const Spec& s, const std::string& as = "") {
  SCOPED_TRACE(f.file().filename().string() + ": " + s.name);
  const auto series = f.open(as.empty() ? s.name : as);
  ASSERT_EQ(series->rows, s.n);
  ASSERT_EQ(series->cols, s.cols);
  std::vector<double> got(s.n * s.cols);
  for (std::size_t at = 0; at < s.n;) {
    const std::size_t k = std::min<std::size_t>(777, s.n - at);
    series->read(k, got.data() + at * s.cols);
    at += k;
  }
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < s.n; ++i)
    for (std::size_t c = 0; c < s.cols; ++c)
      if (got[i * s.cols + c] != expected(s.descr, i, c) && wrong++ == 0)
        ADD_FAILURE() << "row " << i << " col " << c << ": " << got[i * s.cols + c] << ", written " << expected(s.descr, i, c);
  EXPECT_EQ(wrong, 0u);
}

void expect_info(const io::detail::ArrayInfo& a, const Spec& s) {
  EXPECT_EQ(a.name, s.name);
  EXPECT_EQ(a.rows, s.n) << s.name;
  EXPECT_EQ(a.cols, s.cols) << s.name;
  EXPECT_EQ(a.type, s.type) << s.name;
}

// The ImportError `call` throws (its message and byte offset).
template <class F>
ImportError import_error(F call) {
  try {
    call();
  } catch (const ImportError& e) {
    return e;
  }
  ADD_FAILURE() << "no ImportError";
  return ImportError("", 0, "none");
}

class NumpyFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!have_numpy()) return;
    dir_ = new TempDir("npy");
    write_numpy_files(dir_->path());
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (!have_numpy()) GTEST_SKIP() << "python3-numpy is not installed (scripts/install-deps.sh installs it): NumPy writes these files";
    ASSERT_TRUE(fs::exists(dir_->path() / "zip64.npz")) << "the NumPy script failed";
  }
  static fs::path path(const std::string& name) { return dir_->path() / name; }
  static TempDir* dir_;
};
TempDir* NumpyFiles::dir_ = nullptr;

}  // namespace

TEST_F(NumpyFiles, EveryDtypeOrderAndShapeOfNpSaveRoundTripsExactly) {
  for (const Spec& s : specs()) {
    const auto f = io::detail::open_npy(path(std::string(s.name) + ".npy"));
    EXPECT_EQ(f->layout(), "NumPy .npy (version 1.0)");
    ASSERT_EQ(f->arrays().size(), 1u) << s.name;
    expect_info(f->arrays()[0], s);
    expect_values(*f, s);
    EXPECT_EQ(f->damage(), "");
  }
}

TEST_F(NumpyFiles, FormatVersions2And3AreRead) {
  const auto v2 = io::detail::open_npy(path("v2.npy"));
  EXPECT_EQ(v2->layout(), "NumPy .npy (version 2.0)");
  expect_values(*v2, specs()[0], "v2");
  const auto v3 = io::detail::open_npy(path("v3.npy"));
  EXPECT_EQ(v3->layout(), "NumPy .npy (version 3.0)");
  const Spec& acc = *std::find_if(specs().begin(), specs().end(), [](const Spec& s) { return s.name == std::string("acc_3xN"); });
  expect_values(*v3, acc, "v3");
}

TEST_F(NumpyFiles, NpzStoredDeflatedAndZip64RoundTripExactly) {
  const std::string unread = "; not read: 'labels' (dtype '<U2' (integers of 1, 2, 4 or 8 bytes and floats of 4 or 8 are read)), "
                             "'cplx' (dtype '<c16' (integers of 1, 2, 4 or 8 bytes and floats of 4 or 8 are read)), "
                             "'cube' (3 dimensions (2, 3, 4) (1 or 2 are read))";
  const std::string n = std::to_string(specs().size());
  for (const auto& [file, layout] : std::vector<std::pair<std::string, std::string>>{
           {"stored.npz", "NumPy .npz (stored), " + n + " arrays" + unread},
           {"deflated.npz", "NumPy .npz (deflated), " + n + " arrays" + unread},
           {"zip64.npz", "NumPy .npz (deflated), " + n + " arrays"}}) {
    const auto f = io::detail::open_npy(path(file));
    EXPECT_EQ(f->layout(), layout);
    const auto arrays = f->arrays();
    ASSERT_EQ(arrays.size(), specs().size()) << file;
    for (std::size_t k = 0; k < arrays.size(); ++k) expect_info(arrays[k], specs()[k]);  // in the order saved
    for (const Spec& s : specs()) expect_values(*f, s);
    EXPECT_THROW(f->open("labels"), ImportError);
  }
}

TEST_F(NumpyFiles, Zip64RecordsAreWhereTheSizesAndOffsetsAreRead) {
  // The archive's end record points to the zip64 one, and every entry beyond 1000 bytes stores its
  // offset in a zip64 extra field: the listing is the same as the plain archive's.
  const std::string bytes = read_text(path("zip64.npz"));
  EXPECT_NE(bytes.find(std::string("PK\x06\x06", 4)), std::string::npos);
  EXPECT_NE(bytes.find(std::string("PK\x06\x07", 4)), std::string::npos);
  const auto members = io::detail::zip_members(io::detail::BinaryReader(path("zip64.npz")));
  const auto plain = io::detail::zip_members(io::detail::BinaryReader(path("deflated.npz")));
  ASSERT_EQ(members.size(), specs().size());
  for (std::size_t k = 0; k < members.size(); ++k) {
    EXPECT_EQ(members[k].name, plain[k].name);
    EXPECT_EQ(members[k].size, plain[k].size);
    EXPECT_TRUE(members[k].deflated());
  }
  EXPECT_GT(members.back().header, 1000u);
}

TEST_F(NumpyFiles, ReadersOfOneArrayAreIndependent) {
  const auto f = io::detail::open_npy(path("deflated.npz"));
  const Spec& s = specs()[0];
  auto a = f->open(s.name), b = f->open(s.name);
  std::vector<double> ra(30), rb(3);
  a->read(10, ra.data());
  for (std::size_t i = 0; i < 10; ++i) {
    b->read(1, rb.data());
    for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(rb[c], expected(s.descr, i, c));
  }
  a->read(10, ra.data());
  EXPECT_EQ(ra[0], expected(s.descr, 10, 0));
}

TEST_F(NumpyFiles, DetectedByContentAlsoWhenArraysAreNamed) {
  EXPECT_TRUE(looks_like_npy(path("f8.npy")));
  EXPECT_TRUE(looks_like_npy(path("stored.npz")));
  EXPECT_TRUE(looks_like_npy(path("deflated.npz")));
  EXPECT_FALSE(looks_like_npy(path("write.py")));
  ASSERT_NO_FATAL_FAILURE(run_python(dir_->path(), "import sys, zipfile\n"
                                                   "with zipfile.ZipFile(sys.argv[1] + '/notes.zip', 'w') as z:\n"
                                                   "    z.writestr('notes.txt', 'not arrays')\n"));
  EXPECT_FALSE(looks_like_npy(path("notes.zip")));
  ImportOptions o;
  o.set("accel", "acc_3xN");
  o.set("rate_hz", "100");
  EXPECT_EQ(detect_format({path("deflated.npz")}, o).name, "npy");
  EXPECT_EQ(detect_format({path("f8.npy")}).name, "npy");
}

// --- damage -----------------------------------------------------------------------------------

namespace {

// A .npy of version 1.0 written byte by byte: `dict` padded to a 64-byte header, then `values`.
std::string npy_bytes(const std::string& dict, const std::string& values, char version = 1) {
  std::string h = dict;
  h += std::string((64 - (10 + h.size() + 1) % 64) % 64, ' ') + "\n";
  std::string out = std::string("\x93NUMPY", 6) + version + '\0';
  out += static_cast<char>(h.size() & 0xff);
  out += static_cast<char>(h.size() >> 8);
  return out + h + values;
}
std::string f8_values(std::size_t n) {
  std::string v(n * 8, '\0');
  for (std::size_t i = 0; i < n; ++i) {
    const double x = static_cast<double>(i);
    std::memcpy(v.data() + i * 8, &x, 8);
  }
  return v;
}

}  // namespace

TEST(NpyDamage, EachIsRefusedAtItsByteOffset) {
  TempDir dir("npy-damage");
  struct Case {
    const char* what;
    std::string bytes;
    std::uint64_t offset;
    const char* says;
  };
  const std::string ok = "{'descr': '<f8', 'fortran_order': False, 'shape': (100, 3), }";
  const std::string huge = "{'descr': '<f8', 'fortran_order': False, 'shape': (4611686018427387904, 4611686018427387904), }";
  const std::uint64_t ok_data = npy_bytes(ok, "").size(), huge_data = npy_bytes(huge, "").size();  // the values' offsets
  const std::vector<Case> cases = {
      {"no magic", "NUMPY but not quite" + f8_values(10), 0, "no .npy magic"},
      {"short", std::string("\x93NUM", 4), 0, "shorter than a .npy preamble"},
      {"version 4.0", npy_bytes(ok, f8_values(300), 4), 6, ".npy version 4.0"},
      {"header cut", npy_bytes(ok, "").substr(0, 40), 8, "declares 118 bytes where 30 remain"},
      {"values cut", npy_bytes(ok, f8_values(299)), ok_data, "declares shape (100, 3) of <f8 where 2392 bytes of values follow"},
      {"not a dict", npy_bytes("{'descr': '<f8', 'fortran_order': Maybe, 'shape': (100, 3), }", f8_values(300)), 10 + 34,
       "not a Python dict literal: unexpected 'M'"},
      {"no shape", npy_bytes("{'descr': '<f8', 'fortran_order': False}", f8_values(300)), 10, "has no 'shape'"},
      {"negative dim", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (-1, 3), }", f8_values(300)), 10,
       "'shape' holds other than counts"},
      {"huge dims", npy_bytes(huge, ""), huge_data, "declares shape (4611686018427387904, 4611686018427387904)"},
      // the 33rd '(' of the value, after "{'descr': " (10 bytes of the header, which starts at byte 10)
      {"nested", npy_bytes("{'descr': " + std::string(200, '(') + std::string(200, ')') + "}", ""), 10 + 10 + 32,
       "nested deeper than 32 levels"},
      {"unterminated", npy_bytes("{'descr': '<f8", ""), 64, "a string without its closing quote"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    write_text(dir / "a.npy", c.bytes);
    const ImportError e = import_error([&] { io::detail::open_npy(dir / "a.npy"); });
    EXPECT_EQ(e.offset().value_or(~0ull), c.offset) << e.what();
    EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
  }
}

TEST(NpyDamage, AnArrayStendDoesNotReadIsListedAsSuchNotRefused) {
  TempDir dir("npy-unread");
  write_text(dir / "z.npy", npy_bytes("{'descr': '<c16', 'fortran_order': False, 'shape': (4,), }", std::string(64, '\0')));
  const auto f = io::detail::open_npy(dir / "z.npy");
  EXPECT_TRUE(f->arrays().empty());
  EXPECT_NE(f->layout().find("not read: 'z' (dtype '<c16'"), std::string::npos) << f->layout();
  EXPECT_THROW(f->open("z"), ImportError);
}

// Fuzz finding (import_npy_named): an array named for a sensor with no columns or no rows was taken
// as a triad or column of nothing and indexed as one.
TEST(NpyDamage, ANamedArrayWithoutValuesIsRefusedByName) {
  TempDir dir("npy-empty");
  write_text(dir / "A.npy", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (40, 3), }", f8_values(120)));
  for (const char* shape : {"(40, 0)", "(0, 3)", "(0,)"}) {
    SCOPED_TRACE(shape);
    write_text(dir / "T.npy", npy_bytes(std::string("{'descr': '<f8', 'fortran_order': False, 'shape': ") + shape + ", }", ""));
    for (const char* role : {"temperature", "time", "gyro"}) {
      ImportOptions o;
      o.set("accel", "A");
      o.set(role, "T");
      o.set("rate_hz", "100");
      const ImportError e = import_error([&] { open_dataset({dir / "A.npy", dir / "T.npy"}, "npy", o); });
      EXPECT_NE(std::string(e.what()).find("'T' is "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("it holds no values"), std::string::npos) << e.what();
    }
  }
}

TEST_F(NumpyFiles, DamagedArchivesAreRefusedAtTheirByteOffsets) {
  const std::string good = read_text(path("deflated.npz"));
  const auto members = io::detail::zip_members(io::detail::BinaryReader(path("deflated.npz")));
  const io::detail::ZipMember& f8 = members[0];  // 240 kB of float64, deflated
  ASSERT_EQ(f8.name, "f8.npy");
  const auto damaged = [&](const std::string& bytes) {
    write_text(path("damaged.npz"), bytes);
    return path("damaged.npz");
  };

  // Cut short: the end of central directory record is gone.
  const ImportError cut = import_error([&] { io::detail::open_npy(damaged(good.substr(0, good.size() / 2))); });
  EXPECT_NE(std::string(cut.what()).find("no end of central directory record"), std::string::npos) << cut.what();

  // The central directory's offset points past the end (the end record is the last 22 bytes).
  std::string far = good;
  const std::size_t end = far.rfind(std::string("PK\x05\x06", 4));
  far[end + 19] = '\x7f';
  const ImportError beyond = import_error([&] { io::detail::open_npy(damaged(far)); });
  EXPECT_EQ(beyond.offset().value_or(~0ull), end) << beyond.what();
  EXPECT_NE(std::string(beyond.what()).find("lies beyond the file's end"), std::string::npos) << beyond.what();

  // A member declaring more than deflate can inflate from its bytes.
  std::string bomb = good;
  const std::size_t entry = bomb.find(std::string("PK\x01\x02", 4));
  const std::uint32_t huge = 0x7fffffff;
  std::memcpy(bomb.data() + entry + 24, &huge, 4);
  const ImportError declared = import_error([&] { io::detail::open_npy(damaged(bomb)); });
  EXPECT_EQ(declared.offset().value_or(~0ull), f8.header) << declared.what();
  EXPECT_NE(std::string(declared.what()).find("deflate inflates at most 1032 bytes from one"), std::string::npos) << declared.what();

  // Bytes of the deflate stream overwritten: the values are refused where the stream (or, if it
  // still inflates, its CRC) says, inside the member.
  std::string flipped = good;
  for (std::size_t k = 0; k < 64; ++k) flipped[f8.data + f8.compressed / 2 + k] = static_cast<char>(0xa5 ^ k);
  const auto f = io::detail::open_npy(damaged(flipped));
  const ImportError stream = import_error([&] {
    auto s = f->open("f8");
    std::vector<double> v(s->rows * s->cols);
    s->read(s->rows, v.data());
  });
  EXPECT_GE(stream.offset().value_or(0), f8.header) << stream.what();
  EXPECT_LE(stream.offset().value_or(~0ull), f8.data + f8.compressed) << stream.what();
  EXPECT_NE(std::string(stream.what()).find("member 'f8.npy'"), std::string::npos) << stream.what();
}

TEST_F(NumpyFiles, AStoredValueChangedFailsItsCrc) {
  std::string bytes = read_text(path("stored.npz"));
  const auto members = io::detail::zip_members(io::detail::BinaryReader(path("stored.npz")));
  const io::detail::ZipMember& i2 = members[2];
  ASSERT_EQ(i2.name, "i2.npy");
  bytes[i2.data + i2.size - 3] ^= 0x10;
  write_text(path("crc.npz"), bytes);
  const auto f = io::detail::open_npy(path("crc.npz"));
  auto s = f->open("i2");
  std::vector<double> v(s->rows * s->cols);
  const ImportError e = import_error([&] { s->read(s->rows, v.data()); });
  EXPECT_EQ(e.offset().value_or(~0ull), i2.header) << e.what();
  EXPECT_NE(std::string(e.what()).find("CRC-32"), std::string::npos) << e.what();
}

// --- through the format table and `stend import` -------------------------------------------------

namespace {

constexpr std::size_t kSamples = 1000;

// imu.npz as a logger's script saves it: accelerometer counts (int16, 16384 per g) and gyroscope
// rad/s (float32) as six 1-D arrays, deflated.
void write_imu_npz(const fs::path& dir) {
  run_python(dir, R"(import sys, numpy as np
i = np.arange()" + std::to_string(kSamples) + R"()
acc = [(i % 7) - 3, 40 - (i % 11), 16384 + (i % 5)]
gyr = [((i % 13) - 6) / 1024, ((i % 17) - 8) / 2048, ((i % 19) - 9) / 4096]
np.savez_compressed(sys.argv[1] + '/imu.npz',
    **{'accelerometer_' + a: acc[k].astype(np.int16) for k, a in enumerate('xyz')},
    **{'gyroscope_' + a: gyr[k].astype(np.float32) for k, a in enumerate('xyz')})
)");
}
std::array<double, 3> acc_counts(std::size_t i) {
  const auto k = static_cast<double>(i);
  return {std::fmod(k, 7) - 3, 40 - std::fmod(k, 11), 16384 + std::fmod(k, 5)};
}
std::array<double, 3> gyro_radps(std::size_t i) {
  const auto k = static_cast<double>(i);
  return {(std::fmod(k, 13) - 6) / 1024, (std::fmod(k, 17) - 8) / 2048, (std::fmod(k, 19) - 9) / 4096};
}

const char* kImuArgs = " --accel accelerometer_x,accelerometer_y,accelerometer_z --accel-lsb 1/16384g"
                       " --gyro gyroscope_x,gyroscope_y,gyroscope_z --gyro-unit rad/s --rate-hz 100";

void expect_samples(const Recording& rec) {
  std::size_t i = 0, wrong = 0;
  const double lsb = physics::kStandardGravity / 16384;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* s, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k, ++i) {
      const auto a = acc_counts(i), g = gyro_radps(i);
      bool ok = std::abs(s[k].t_s - static_cast<double>(i) / 100) < 1e-9;
      for (int c = 0; c < 3; ++c)
        ok = ok && s[k].accel_counts[c] == a[c] && s[k].accel_mps2[c] == a[c] * lsb && s[k].gyro_radps[c] == g[c];
      if (!ok && wrong++ == 0) ADD_FAILURE() << "sample " << i << " differs from what was written";
    }
  });
  EXPECT_EQ(i, kSamples);
  EXPECT_EQ(wrong, 0u);
}

}  // namespace

TEST(ImportNpz, CountsAndRadiansPerSecondBecomeSamples) {
  SKIP_WITHOUT_NUMPY();
  TempDir dir("npz-import");
  ASSERT_NO_FATAL_FAILURE(write_imu_npz(dir.path()));
  ImportOptions o;
  o.set("accel", "accelerometer_x,accelerometer_y,accelerometer_z");
  o.set("accel_lsb", "1/16384g");
  o.set("gyro", "gyroscope_x,gyroscope_y,gyroscope_z");
  o.set("gyro_unit", "rad/s");
  o.set("rate_hz", "100");
  std::string used;
  const Recording rec = open_dataset({dir / "imu.npz"}, "auto", o, &used);
  EXPECT_EQ(used, "npy");
  expect_samples(rec);
}

TEST(ImportNpz, StendImportWorkedExample) {
  SKIP_WITHOUT_NUMPY();
  TempDir dir("npz-cli");
  ASSERT_NO_FATAL_FAILURE(write_imu_npz(dir.path()));
  const auto out = stend::testing::run_stend("import " + (dir / "imu.npz").string() + kImuArgs + " -o " + (dir / "run").string());
  ASSERT_EQ(out.code, 0) << out.text;
  EXPECT_NE(out.text.find("format:     npy"), std::string::npos) << out.text;
  EXPECT_NE(out.text.find("read:       imported 1000 samples (imu.npz: NumPy .npz (deflated), 6 arrays): accel "
                          "'accelerometer_x','accelerometer_y','accelerometer_z'"),
            std::string::npos)
      << out.text;
  expect_samples(Recording::open(dir / "run", SampleLoading::kStream));
}

// Crafted: an .npz of 64 000 one-value members beside the IMU arrays, written by Python's zipfile.
// Each member's name is checked against the others through a set (it was compared with every
// array before it: 8 s for these).
TEST(ImportNpz, ManyMembersAreLinearInTime) {
  TempDir dir("npz-members");
  ASSERT_NO_FATAL_FAILURE(run_python(dir.path(), R"(import struct, sys, zipfile
def npy(shape, values):
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': %s, }" % (repr(shape),)
    header += ' ' * (63 - (10 + len(header)) % 64) + '\n'
    return b'\x93NUMPY\x01\x00' + struct.pack('<H', len(header)) + header.encode() + struct.pack('<%dd' % len(values), *values)
with zipfile.ZipFile(sys.argv[1] + '/many.npz', 'w', zipfile.ZIP_STORED, allowZip64=True) as z:
    z.writestr('acc.npy', npy((200, 3), [0.0, 0.0, 9.81] * 200))
    z.writestr('gyro.npy', npy((200, 3), [0.0, 0.01, 0.0] * 200))
    one = npy((1,), [1.0])
    for i in range(64000):
        z.writestr('d%d.npy' % i, one)
)"));
  ImportOptions o;
  o.set("accel", "acc");
  o.set("gyro", "gyro");
  o.set("rate_hz", "100");
  const auto start = std::chrono::steady_clock::now();
  std::string used;
  const Recording rec = open_dataset({dir / "many.npz"}, "auto", o, &used);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  EXPECT_EQ(used, "npy");
  EXPECT_EQ(rec.sample_source().size(), 200u);
}

TEST(ImportNpz, OneNpyPerSensorEachA4xNBufferWithItsOwnTime) {
  SKIP_WITHOUT_NUMPY();
  TempDir dir("npy-sensors");
  // accelerometer at 100 Hz in g, gyroscope at 200 Hz in deg/s from 5 ms later, each [t; x; y; z].
  ASSERT_NO_FATAL_FAILURE(run_python(dir.path(), R"(import sys, numpy as np
t = np.arange(500) / 100
np.save(sys.argv[1] + '/acc.npy', np.vstack([t, 0.001 * (np.arange(500) % 7), 0 * t, 1 + 0 * t]))
u = 0.005 + np.arange(1000) / 200
np.save(sys.argv[1] + '/gyro.npy', np.vstack([u, 10 * u, -2 * u, 0.5 + 0 * u]).astype('<f4'))
)"));
  ImportOptions o;
  o.set("accel", "acc");
  o.set("gyro", "gyro");
  o.set("accel_unit", "g");
  o.set("gyro_unit", "deg/s");
  std::string used;
  const Recording rec = open_dataset({dir / "acc.npy", dir / "gyro.npy"}, "auto", o, &used);
  EXPECT_EQ(used, "npy");
  std::size_t i = 0, wrong = 0;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* s, std::size_t n, std::uint64_t) {
    for (std::size_t k = 0; k < n; ++k, ++i) {
      const double t = s[k].t_s;  // the accelerometer's times from 0.01 s: 0 is before the gyroscope's first
      const double ax = 0.001 * static_cast<double>((i + 1) % 7) * physics::kStandardGravity;
      const double gx = static_cast<double>(static_cast<float>(10 * t)) * physics::kDegPerSecond;
      const bool ok = std::abs(t - static_cast<double>(i + 1) / 100) < 1e-9 && s[k].accel_mps2[0] == ax &&
                      std::abs(s[k].gyro_radps[0] - gx) < 1e-6 && std::abs(s[k].gyro_radps[2] - 0.5 * physics::kDegPerSecond) < 1e-12;
      if (!ok && wrong++ == 0) ADD_FAILURE() << "sample " << i << " at " << t << " s";
    }
  });
  EXPECT_EQ(i, 499u);
  EXPECT_EQ(wrong, 0u);
}
