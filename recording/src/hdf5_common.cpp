// What the HDF5 run store's writer and reader share (see hdf5_common.hpp).
#include "hdf5_common.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <cstring>
#include <string_view>
#include <vector>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

std::mutex& hdf5_mutex() {
  static std::mutex m;
  return m;
}

// libhdf5 closes the files still open when the process exits (H5_term_library, at exit); a file
// whose writes failed (a full disk, a file-size limit) makes it crash there, after Stend has said
// what failed. Stend closes every file it opens itself, so that pass is not registered: this runs
// when the library is loaded, before any other libhdf5 call.
[[maybe_unused]] const herr_t kNoHdf5Atexit = H5dont_atexit();

// The system's reason inside libhdf5's text of a failed write ("…, errno = 27, error message =
// 'File too large', …"), or "" when it has none.
std::string system_reason(const std::string& hdf5_text) {
  constexpr std::string_view kKey = "error message = '";
  const auto at = hdf5_text.find(kKey);
  if (at == std::string::npos) return {};
  const auto from = at + kKey.size();
  const auto to = hdf5_text.find('\'', from);
  return to == std::string::npos ? std::string() : hdf5_text.substr(from, to - from);
}

}  // namespace

Hdf5Lock::Hdf5Lock() {
  static const bool threadsafe = [] {
    hbool_t ts = 0;
    H5is_library_threadsafe(&ts);
    return ts > 0;
  }();
  if (!threadsafe) lock = std::unique_lock<std::mutex>(hdf5_mutex());
}

std::string hdf5_error() {
  std::vector<std::string> msgs;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD,
           [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
             auto& out = *static_cast<std::vector<std::string>*>(data);
             if (n < 3 && e->desc) out.emplace_back(e->desc);
             return 0;
           },
           &msgs);
  H5Eclear2(H5E_DEFAULT);
  std::string s;
  for (const auto& m : msgs) s += (s.empty() ? "" : "; ") + m;
  return s.empty() ? "HDF5 error" : s;
}

void fail(const fs::path& file, const std::string& what) {
  throw InputError(fmt::format("{}: {} ({})", file.string(), what, hdf5_error()));
}

void fail_write(const fs::path& file, const std::string& what) {
  const std::string text = hdf5_error();
  const std::string reason = system_reason(text);
  if (!reason.empty()) throw IoError(fmt::format("{}: {}: {}", file.string(), what, reason));
  throw IoError(fmt::format("{}: {} ({})", file.string(), what, text));
}

Handle check(hid_t id, herr_t (*close)(hid_t), const fs::path& file, const std::string& what) {
  if (id < 0) fail(file, what);
  return Handle(id, close);
}

void check(herr_t r, const fs::path& file, const std::string& what) {
  if (r < 0) fail(file, what);
}

Handle check_write(hid_t id, herr_t (*close)(hid_t), const fs::path& file, const std::string& what) {
  if (id < 0) fail_write(file, what);
  return Handle(id, close);
}

void check_write(herr_t r, const fs::path& file, const std::string& what) {
  if (r < 0) fail_write(file, what);
}


// --- attributes ---------------------------------------------------------------------------------

Handle fixed_string_type(std::size_t bytes) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), bytes);
  H5Tset_strpad(t.get(), H5T_STR_NULLPAD);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

Handle vl_string_type() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

namespace {

// Creates or overwrites a scalar attribute of `type`.
void put_attr(hid_t obj, const char* name, hid_t type, const void* value, const fs::path& file) {
  if (H5Aexists(obj, name) > 0) H5Adelete(obj, name);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a = check_write(H5Acreate2(obj, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                         file, fmt::format("cannot create attribute '{}'", name));
  check_write(H5Awrite(a.get(), type, value), file, fmt::format("cannot write attribute '{}'", name));
}
}  // namespace

// NUL-padded to at least one byte (HDF5 has no zero-size type).
void put_attr(hid_t obj, const char* name, const std::string& v, const fs::path& file) {
  std::string bytes = v;
  if (bytes.empty()) bytes.push_back('\0');
  const Handle t = fixed_string_type(bytes.size());
  put_attr(obj, name, t.get(), bytes.data(), file);
}
void put_attr(hid_t obj, const char* name, double v, const fs::path& file) {
  put_attr(obj, name, H5T_NATIVE_DOUBLE, &v, file);
}
void put_attr(hid_t obj, const char* name, std::int64_t v, const fs::path& file) {
  put_attr(obj, name, H5T_NATIVE_INT64, &v, file);
}

// --- datasets -----------------------------------------------------------------------------------

Handle create_dataset(hid_t loc, const DatasetSpec& s, const fs::path& file) {
  const int rank = s.cols ? 2 : 1;
  const hsize_t dims[2] = {0, s.cols};
  const hsize_t maxdims[2] = {H5S_UNLIMITED, s.cols};
  const hsize_t chunk[2] = {s.chunk_rows, s.cols ? s.cols : 1};
  Handle space(H5Screate_simple(rank, dims, maxdims), H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(dcpl.get(), rank, chunk);
  if (s.compress) {
    H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 1);
  }
  H5Pset_fletcher32(dcpl.get());  // a damaged chunk is an error on read, never wrong numbers
  return check_write(H5Dcreate2(loc, s.name, s.type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                     H5Dclose, file, fmt::format("cannot create dataset '{}'", s.name));
}

void write_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, const void* data,
                const fs::path& file, const char* name) {
  if (rows == 0) return;
  const int rank = cols ? 2 : 1;
  const hsize_t new_dims[2] = {at + rows, cols};
  check_write(H5Dset_extent(ds, new_dims), file, fmt::format("cannot extend dataset '{}'", name));
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const hsize_t start[2] = {at, 0};
  const hsize_t count[2] = {rows, cols};
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
  Handle mspace(H5Screate_simple(rank, count, nullptr), H5Sclose);
  check_write(H5Dwrite(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, data), file,
              fmt::format("cannot write dataset '{}'", name));
}

hsize_t extent_rows(hid_t ds) {
  Handle space(H5Dget_space(ds), H5Sclose);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  return dims[0];
}

herr_t read_rows(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, hsize_t cols, void* out) {
  if (rows == 0) return 0;
  const int rank = cols ? 2 : 1;
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const hsize_t start[2] = {at, 0};
  const hsize_t count[2] = {rows, cols};
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
  Handle mspace(H5Screate_simple(rank, count, nullptr), H5Sclose);
  return H5Dread(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, out);
}

// --- text datasets ------------------------------------------------------------------------------

void write_text(hid_t ds, std::size_t bytes, std::string_view text, const fs::path& file) {
  std::string v(text.substr(0, bytes));
  v.resize(bytes, '\0');
  const Handle t = fixed_string_type(bytes);
  check_write(H5Dwrite(ds, t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), file, "cannot write a text dataset");
}

Handle create_text(hid_t loc, const char* name, std::size_t bytes, std::string_view text, const fs::path& file) {
  const Handle t = fixed_string_type(bytes);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle ds = check_write(H5Dcreate2(loc, name, t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                          H5Dclose, file, fmt::format("cannot create dataset '{}'", name));
  write_text(ds.get(), bytes, text, file);
  return ds;
}

std::string read_text(hid_t loc, const char* name, const fs::path& file) {
  Handle ds = check(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose, file, fmt::format("dataset /{} is missing or damaged", name));
  Handle ft(H5Dget_type(ds.get()), H5Tclose);
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const std::size_t bytes = H5Tget_size(ft.get());
  // Only what the writer makes: one fixed-length string of at most kMessageBytes.
  if (H5Tget_class(ft.get()) != H5T_STRING || H5Tis_variable_str(ft.get()) != 0 || value_count(space.get()) != 1 ||
      bytes == 0 || bytes > kMessageBytes)
    fail(file, fmt::format("dataset /{} is not a fixed-length string of at most {} bytes (damaged)", name, kMessageBytes));
  const Handle t = fixed_string_type(bytes);
  std::string v(bytes, '\0');
  check(H5Dread(ds.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), file, fmt::format("dataset /{} is damaged", name));
  v.resize(std::strlen(v.c_str()));
  return v;
}

}  // namespace stend::detail
