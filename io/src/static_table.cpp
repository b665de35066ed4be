// The table-of-static-means importer (import_static_table in stend/io/importers.hpp): one row per
// static position, the known input (angle or specific force) and the measured means.
#include "import_common.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>
#include <stend/physics/units.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// Which columns of a static table hold the known input and the measured means (−1 = absent).
struct TableColumns {
  int angle = -1;
  std::array<int, 3> force{-1, -1, -1}, measured{-1, -1, -1};
};

TableColumns table_columns(const LineReader& r, const std::vector<std::string>& names) {
  TableColumns c;
  auto find = [&](const std::string& n) {
    const auto it = std::find(names.begin(), names.end(), n);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  c.angle = find("angle_deg");
  bool any = false;
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string axis(1, static_cast<char>('x' + k));
    c.force[k] = find("f_" + axis + "_mps2");
    c.measured[k] = find("a_" + axis + "_mps2");
    any = any || c.measured[k] >= 0;
  }
  const bool force = c.force[0] >= 0 && c.force[1] >= 0 && c.force[2] >= 0;
  if (!any) r.fail("no measured column: expected a_x_mps2, a_y_mps2 and/or a_z_mps2");
  if ((c.angle >= 0) == force)
    r.fail("expected the known input as either angle_deg or f_x_mps2,f_y_mps2,f_z_mps2 (exactly one of them)");
  return c;
}

}  // namespace

Recording import_static_table(const fs::path& file, double gravity_mps2) {
  LineReader r(file);
  std::string line;
  std::vector<std::string> names;
  while (names.empty() && r.next(line)) {
    if (is_blank(line) || trim(line).front() == '#') continue;
    for (auto f : split(line, ',')) names.push_back(unquote(f));
  }
  if (names.empty()) throw ImportError(file, 0, "no column-name line");
  const TableColumns c = table_columns(r, names);
  Recording rec = new_recording(file, "static_table");
  rec.header.gravity_mps2 = gravity_mps2;
  const double g = rec.header.gravity_or_standard_mps2();
  const auto per_row = static_cast<std::size_t>(kStaticTableHold_s * kStaticTableRate_hz);
  while (r.next(line)) {
    if (is_blank(line) || trim(line).front() == '#') continue;
    const auto f = split(line, ',');
    if (f.size() != names.size()) {
      r.fail("expected " + std::to_string(names.size()) + " fields, found " + std::to_string(f.size()));
    }
    std::array<double, 3> force{};
    std::string label;
    if (c.angle >= 0) {
      const double delta = number(r, f[static_cast<std::size_t>(c.angle)], "angle_deg");
      const Eigen::Vector3d fv = physics::gravity_specific_force(physics::paper_table(0.0, delta * physics::kDegToRad), g);
      force = {fv.x(), fv.y(), fv.z()};
      label = fmt_g(delta) + " deg";
    } else {
      for (std::size_t k = 0; k < 3; ++k) force[k] = number(r, f[static_cast<std::size_t>(c.force[k])], names[static_cast<std::size_t>(c.force[k])]);
      label = "row " + std::to_string(rec.segments.size() + 1);
    }
    ImuSample s;
    for (std::size_t k = 0; k < 3; ++k) {
      s.accel_mps2[static_cast<int>(k)] = c.measured[k] >= 0 ? number(r, f[static_cast<std::size_t>(c.measured[k])], names[static_cast<std::size_t>(c.measured[k])])
                                                            : std::numeric_limits<double>::quiet_NaN();
    }
    const double t0 = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
    for (std::size_t i = 0; i < per_row; ++i) {
      s.t_s = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
      rec.samples.push_back(s);
    }
    const int id = static_cast<int>(rec.segments.size());
    Segment seg = make_segment(id, SegmentKind::kOrientation, label, t0, rec.samples.back().t_s);
    seg.orientation = id;
    rec.segments.push_back(seg);
    add_held_truth(rec, seg.t_start_s, seg.t_end_s, force);
  }
  if (rec.segments.empty()) throw ImportError(file, 0, "no data rows after the column names");
  for (auto& seg : rec.segments) seg.orientation_count = static_cast<int>(rec.segments.size());
  rec.header.info.output_rate_hz = kStaticTableRate_hz;
  rec.header.info.has_gyro = false;
  rec.header.info.has_temperature = false;
  add_import_event(rec, "imported " + std::to_string(rec.segments.size()) + " static means from " + file.string() +
                            " (table of static means; each row held as an orientation segment of " +
                            fmt_g(kStaticTableHold_s) + " s at " + fmt_g(kStaticTableRate_hz) +
                            " Hz repeating the mean, so sample statistics carry no noise information; " +
                            (c.angle >= 0 ? "known input from angle_deg: f = g*[-sin d, 0, cos d], the paper's table with tilt h = 0, g = " +
                                                fmt_g(g) + " m/s^2" + (gravity_mps2 > 0.0 ? "" : " (standard gravity: the table does not state g)")
                                          : std::string("known input from f_x_mps2, f_y_mps2, f_z_mps2")) +
                            "; axes without a measured column read NaN)");
  return rec;
}

}  // namespace stend::io
