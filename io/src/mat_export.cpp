// A recording written as a MATLAB file (export_mat in stend/io/importers.hpp) through matio: the
// variables import_mat reads back, at the top level or as the fields of one struct.
#include "mat_file.hpp"

#include <stend/errors.hpp>
#include <stend/model/terms.hpp>
#include <stend/recording/instruments.hpp>

#include <cstdint>
#include <utility>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// matio could not make or write what it was asked: the file is not written.
[[noreturn]] void write_failed(const fs::path& file, const std::string& what) {
  throw IoError(file.string() + ": " + what);
}

MatVar make_double(const char* name, std::size_t rows, std::size_t cols, const double* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(matio().Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<double*>(data), 0));
}
MatVar make_int32(const char* name, std::size_t rows, std::size_t cols, const std::int32_t* data) {
  std::size_t dims[2] = {rows, cols};
  return MatVar(matio().Mat_VarCreate(name, MAT_C_INT32, MAT_T_INT32, 2, dims, const_cast<std::int32_t*>(data), 0));
}
MatVar make_text(const char* name, const std::string& s) {
  std::size_t dims[2] = {1, s.size()};
  return MatVar(matio().Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UINT8, 2, dims, const_cast<char*>(s.data()), 0));
}

// The samples as column-major N x 1 / N x 3 arrays: time [s], acceleration [m/s²], rate [rad/s],
// their counts, temperature [°C].
struct MatColumns {
  std::vector<double> t, acc, gyr, temp;
  std::vector<std::int32_t> acc_c, gyr_c;
};

MatColumns mat_columns(const Recording& rec) {
  const std::size_t n = rec.samples.size();
  MatColumns m{std::vector<double>(n), std::vector<double>(3 * n), std::vector<double>(3 * n), std::vector<double>(n),
               std::vector<std::int32_t>(3 * n), std::vector<std::int32_t>(3 * n)};
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& s = rec.samples[i];
    m.t[i] = s.t_s;
    m.temp[i] = s.temperature_c;
    for (std::size_t k = 0; k < 3; ++k) {
      const int ik = static_cast<int>(k);
      m.acc[i + k * n] = s.accel_mps2[ik];
      m.gyr[i + k * n] = s.gyro_radps[ik];
      m.acc_c[i + k * n] = s.accel_counts[k];
      m.gyr_c[i + k * n] = s.gyro_counts[k];
    }
  }
  return m;
}

// The segments as a struct array with fields kind, label, t_start_s, t_end_s [s].
MatVar segments_struct(const Recording& rec, const fs::path& file) {
  const char* segment_fields[] = {"kind", "label", "t_start_s", "t_end_s", nullptr};
  std::size_t dims[2] = {rec.segments.size(), 1};
  MatVar s(matio().Mat_VarCreateStruct2("segments", 2, dims, segment_fields));
  if (!s) write_failed(file, "matio failed to create 'segments'");
  for (std::size_t i = 0; i < rec.segments.size(); ++i) {
    const Segment& seg = rec.segments[i];
    matio().Mat_VarSetStructFieldByName(s.get(), "kind", i, make_text("kind", to_string(seg.kind)).release());
    matio().Mat_VarSetStructFieldByName(s.get(), "label", i, make_text("label", seg.label).release());
    matio().Mat_VarSetStructFieldByName(s.get(), "t_start_s", i, make_double("t_start_s", 1, 1, &seg.t_start_s).release());
    matio().Mat_VarSetStructFieldByName(s.get(), "t_end_s", i, make_double("t_end_s", 1, 1, &seg.t_end_s).release());
  }
  return s;
}

// Writes variables to a MAT file: at the top level each at once, or (struct_name given)
// collected and written as the fields of one struct by finish().
class MatWriter {
 public:
  MatWriter(mat_t* mat, const fs::path& file, const std::string& struct_name)
      : mat_(mat), file_(file), struct_name_(struct_name) {}

  void write(MatVar v, const char* what) {
    if (!v) write_failed(file_, std::string("matio failed to create '") + what + "'");
    if (!struct_name_.empty()) {
      fields_.emplace_back(what, std::move(v));
      return;
    }
    if (matio().Mat_VarWrite(mat_, v.get(), MAT_COMPRESSION_NONE) != 0) {
      write_failed(file_, std::string("matio failed to write '") + what + "'");
    }
  }

  void finish() {
    if (struct_name_.empty()) return;
    std::vector<const char*> names;
    for (const auto& f : fields_) names.push_back(f.first.c_str());
    names.push_back(nullptr);
    std::size_t dims[2] = {1, 1};
    MatVar root(matio().Mat_VarCreateStruct2(struct_name_.c_str(), 2, dims, names.data()));
    if (!root) write_failed(file_, "matio failed to create struct '" + struct_name_ + "'");
    for (auto& f : fields_) matio().Mat_VarSetStructFieldByName(root.get(), f.first.c_str(), 0, f.second.release());
    if (matio().Mat_VarWrite(mat_, root.get(), MAT_COMPRESSION_NONE) != 0) {
      write_failed(file_, "matio failed to write struct '" + struct_name_ + "'");
    }
  }

 private:
  mat_t* mat_;
  fs::path file_;
  std::string struct_name_;
  std::vector<std::pair<std::string, MatVar>> fields_;
};

}  // namespace

void export_mat(const Recording& rec, const fs::path& file, const std::string& struct_name) {
  MatFile mat(matio().Mat_CreateVer(file.c_str(), nullptr, MAT_FT_MAT5));
  if (!mat) write_failed(file, "matio cannot create it");
  const std::size_t n = rec.samples.size();
  const MatColumns c = mat_columns(rec);
  const double fs_hz = rec.header.info.output_rate_hz;
  const double acc_lsb = rec.header.info.accel_lsb_mps2, gyr_lsb = rec.header.info.gyro_lsb_radps;
  MatWriter w(mat.get(), file, struct_name);
  w.write(make_double("t", n, 1, c.t.data()), "t");
  w.write(make_double("fs", 1, 1, &fs_hz), "fs");
  if (has_instrument(rec.header.info, model::Instrument::kAccelerometer)) {  // an absent one is left out
    w.write(make_double("acc", n, 3, c.acc.data()), "acc");
    w.write(make_int32("acc_counts", n, 3, c.acc_c.data()), "acc_counts");
    w.write(make_double("acc_lsb", 1, 1, &acc_lsb), "acc_lsb");
  }
  if (has_instrument(rec.header.info, model::Instrument::kGyroscope)) {
    w.write(make_double("gyro", n, 3, c.gyr.data()), "gyro");
    w.write(make_int32("gyro_counts", n, 3, c.gyr_c.data()), "gyro_counts");
    w.write(make_double("gyro_lsb", 1, 1, &gyr_lsb), "gyro_lsb");
  }
  if (rec.header.info.has_temperature) w.write(make_double("temp", n, 1, c.temp.data()), "temp");
  if (!rec.segments.empty()) w.write(segments_struct(rec, file), "segments");
  w.finish();
}

}  // namespace stend::io
