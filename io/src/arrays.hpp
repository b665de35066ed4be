// Named numeric arrays in a container file — the variables of a .mat, the arrays of a .npy/.npz,
// the fields of raw binary records — and the one step that makes a recording of them by the names
// the import options give (--time, --accel, --gyro, --temperature). Internal to stend_io.
//
// An array is rows × cols, the samples along the rows: an N×3 (or 3×N, read transposed) triad, an
// N×4 [t x y z] triad with its own time, an N×1 (or 1×N) column. A name selects a whole array
// ("A_xyz"), a struct field ("data.acc"), or one column of an array ("imu:4", 0-based).
#pragma once

#include <stend/io/import_options.hpp>
#include <stend/io/sample_sink.hpp>
#include <stend/recording/recording.hpp>

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace stend::io::detail {

// An array stored a component after the other (a Fortran-order N×C .npy, a C-order 3×N read
// transposed, a MATLAB N×C matrix) is read by one cursor per component, each inflating a compressed
// array anew from its start up to its component: at most this many (a crafted wide array made the
// reading cubic in its width).
inline constexpr std::size_t kMaxComponentCursors = 64;

// The rows of one array read forward a block at a time, so that no array is held whole.
class ArraySeries {
 public:
  ArraySeries(std::string which, std::size_t n_rows, std::size_t n_cols)
      : name(std::move(which)), rows(n_rows), cols(n_cols) {}
  virtual ~ArraySeries() = default;
  // The next n rows into out (n × cols values, row after row), converted to double.
  virtual void read(std::size_t n, double* out) = 0;
  // Every value (a scalar, or a short vector).
  std::vector<double> all() {
    std::vector<double> v(rows * cols);
    read(rows, v.data());
    return v;
  }
  std::string name;
  std::size_t rows, cols;
};

// What a container holds: each array's name, shape (samples along rows) and stored type.
struct ArrayInfo {
  std::string name;      // "A_xyz", "data.acc", "ax"
  std::size_t rows = 0;  // samples
  std::size_t cols = 1;  // components
  std::string type;      // as stored: "float64", "int16", "uint8", …
};

// A container of named arrays.
class ArrayFile {
 public:
  virtual ~ArrayFile() = default;
  virtual const std::filesystem::path& file() const = 0;
  // Every numeric array (struct fields as "struct.field"), in the file's order.
  virtual std::vector<ArrayInfo> arrays() const = 0;
  // The array `name` (one of arrays()) read from its first row; each call a new, independent reader.
  virtual std::unique_ptr<ArraySeries> open(const std::string& name) const = 0;
  // The layout found, for the import event and the terminal: "NumPy .npz, 7 arrays", "MAT 7.3 (HDF5)".
  virtual std::string layout() const = 0;
  // Records a cut-off end dropped (raw records: a truncated last record); "" when none.
  virtual std::string damage() const { return ""; }
};

// Containers (npy_file.cpp, records_file.cpp, mat_arrays.cpp).
std::unique_ptr<ArrayFile> open_npy(const std::filesystem::path& file);  // .npy or .npz (stored or deflated)
std::unique_ptr<ArrayFile> open_records(const std::filesystem::path& file, const ImportOptions& options);
std::unique_ptr<ArrayFile> open_mat_arrays(const std::filesystem::path& file);

// The recording of `files` (one or more inputs; a name is looked for in each, in order) with the
// sensors the options name: the time (or a rate), the triads (counts with their LSB, or a unit,
// per sensor), the temperature. Sensors of different lengths or from different files are joined on
// their times (each triad's own time from an N×4 array, else the common time), or by index at the
// stated rate; what was done is stated in the import event. `format` names the format in events.
void import_arrays(const std::vector<const ArrayFile*>& files, const ImportOptions& options, const std::string& format,
                   Recording& rec, SampleSink& out);

}  // namespace stend::io::detail
