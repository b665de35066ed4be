// The table-of-static-means importer (import_static_table in stend/io/importers.hpp): one row per
// static position, the known input (angle or specific force), the measured means and, optionally,
// their noise (n, sigma: held_rows.hpp).
#include "held_rows.hpp"

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

namespace {

// The row's known input as the truth columns hold it (kTruthColumns: f, then zero rate), and its label.
std::vector<double> row_input(const LineReader& r, const std::vector<std::string_view>& f, const TableColumns& c,
                              const std::vector<std::string>& names, double g, std::size_t row, std::string& label) {
  std::array<double, 3> force{};
  if (c.angle >= 0) {
    const double delta = number(r, f[static_cast<std::size_t>(c.angle)], "angle_deg");
    const Eigen::Vector3d fv = physics::gravity_specific_force(physics::paper_table(0.0, delta * physics::kDegToRad), g);
    force = {fv.x(), fv.y(), fv.z()};
    label = fmt_g(delta) + " deg";
  } else {
    for (std::size_t k = 0; k < 3; ++k)
      force[k] = number(r, f[static_cast<std::size_t>(c.force[k])], names[static_cast<std::size_t>(c.force[k])]);
    label = "row " + std::to_string(row);
  }
  return {force[0], force[1], force[2], 0.0, 0.0, 0.0};
}

// The spread columns of a static table: sigma in m/s^2 like its means (a_*_mps2).
SpreadColumns table_spread_columns(const LineReader& r, const std::vector<std::string>& names) {
  const SpreadColumns c = spread_columns(r, names);
  for (const int i : {c.sigma, c.sigma_axis[0], c.sigma_axis[1], c.sigma_axis[2]})
    if (i >= 0 && column_key(names[static_cast<std::size_t>(i)]).unit == "g")
      r.fail("column '" + names[static_cast<std::size_t>(i)] + "': a static table's values are in m/s^2 (a_*_mps2); "
             "give sigma in m/s^2 (sigma_mps2 or sigma_x_mps2, …)");
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
  const SpreadColumns spread = table_spread_columns(r, names);
  Recording rec = new_recording(file, "static_table");
  rec.header.gravity_mps2 = gravity_mps2;
  rec.header.truth_columns = held_truth_columns(kTruthColumns);
  const double g = rec.header.gravity_or_standard_mps2();
  while (r.next(line)) {
    if (is_blank(line) || trim(line).front() == '#') continue;
    const auto f = split(line, ',');
    if (f.size() != names.size()) {
      r.fail("expected " + std::to_string(names.size()) + " fields, found " + std::to_string(f.size()));
    }
    std::string label;
    const std::vector<double> input = row_input(r, f, c, names, g, rec.segments.size() + 1, label);
    Eigen::Vector3d mean = Eigen::Vector3d::Constant(kNaN);
    for (std::size_t k = 0; k < 3; ++k)
      if (c.measured[k] >= 0)
        mean[static_cast<int>(k)] = number(r, f[static_cast<std::size_t>(c.measured[k])], names[static_cast<std::size_t>(c.measured[k])]);
    hold_row(rec, label, mean, input, row_spread(r, f, spread, names, 1.0));
  }
  if (rec.segments.empty()) throw ImportError(file, 0, "no data rows after the column names");
  finish_held_rows(rec);
  add_import_event(rec, "imported " + std::to_string(rec.segments.size()) + " static means from " + file.string() +
                            " (table of static means; " + held_rows_text(spread) + "; noise columns: " +
                            spread.describe(names) + "; " +
                            (c.angle >= 0 ? "known input from angle_deg: f = g*[-sin d, 0, cos d], the paper's table with tilt h = 0, g = " +
                                                fmt_g(g) + " m/s^2" + (gravity_mps2 > 0.0 ? "" : " (standard gravity: the table does not state g)")
                                          : std::string("known input from f_x_mps2, f_y_mps2, f_z_mps2")) +
                            "; axes without a measured column read NaN)");
  return rec;
}

}  // namespace stend::io
