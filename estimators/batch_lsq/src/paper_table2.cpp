// Reproduction of the paper's Table 2 fit. See stend/batch_lsq/paper_table2.hpp.
#include "stend/batch_lsq/paper_table2.hpp"

#include <stend/errors.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "stend/physics/gravity.hpp"
#include "stend/physics/table_chain.hpp"

#ifndef STEND_BATCH_LSQ_SOURCE_DIR
#define STEND_BATCH_LSQ_SOURCE_DIR "."
#endif

namespace stend::batch_lsq::paper {

namespace {

using estimation::number_text;

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const auto b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}
}  // namespace

std::filesystem::path default_table2_csv() {
  return std::filesystem::path(STEND_BATCH_LSQ_SOURCE_DIR) / "datasets" / "paper_table2" /
         "table2.csv";
}

std::vector<Table2Row> load_table2_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError("cannot open '" + file.string() + "'");
  std::vector<Table2Row> rows;
  std::string line;
  int lineno = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++lineno;
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    const std::string where = file.string() + ":" + std::to_string(lineno) + ": ";
    if (!header) {
      if (line != "angle_deg,a_z_mps2")
        throw InputError(where + "expected the header 'angle_deg,a_z_mps2', got '" + line + "'");
      header = true;
      continue;
    }
    const auto comma = line.find(',');
    if (comma == std::string::npos || line.find(',', comma + 1) != std::string::npos)
      throw InputError(where + "expected two comma-separated numbers, got '" + line + "'");
    Table2Row r;
    try {
      std::size_t used = 0;
      const std::string a = trim(line.substr(0, comma)), b = trim(line.substr(comma + 1));
      r.angle_deg = std::stod(a, &used);
      if (used != a.size()) throw std::invalid_argument(a);
      r.a_z_mps2 = std::stod(b, &used);
      if (used != b.size()) throw std::invalid_argument(b);
    } catch (const std::exception&) {
      throw InputError(where + "not a number in '" + line + "'");
    }
    rows.push_back(r);
  }
  if (!header) throw InputError(file.string() + ": no header line 'angle_deg,a_z_mps2'");
  return rows;
}

ModelSpec table2_model() {
  ModelSpec s;
  s.model.instrument = model::Instrument::kAccelerometer;
  s.model.terms = {{model::TermKind::kBias, 1, 25.0},
                   {model::TermKind::kScale, 1, 25.0},
                   {model::TermKind::kCrossAxis, 1, 25.0}};
  s.axes = {2};
  s.source = "paper Table 2 model (built in)";
  return s;
}

std::vector<processing::StaticPoint> table2_points(const std::vector<Table2Row>& rows, double g_mps2,
                                                   double tilt_h_deg) {
  std::vector<processing::StaticPoint> pts;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    processing::StaticPoint p;
    p.segment.id = static_cast<int>(i);
    p.segment.label = number_text(rows[i].angle_deg) + " deg";
    const Eigen::Vector3d f = physics::gravity_specific_force(
        physics::paper_table(tilt_h_deg * physics::kDegToRad, rows[i].angle_deg * physics::kDegToRad), g_mps2);
    p.stimulus.input = f;
    p.stimulus.specific_force = f;
    p.stimulus.temperature_c = 25.0;  // one (unstated) temperature; no temperature terms fitted
    p.accel.mean = Eigen::Vector3d(kNaN, kNaN, rows[i].a_z_mps2);
    pts.push_back(p);
  }
  return pts;
}

Table2Reproduction reproduce_table2(const std::vector<Table2Row>& rows) {
  Table2Reproduction out;
  out.rows = rows;
  const double g_local = physics::normal_gravity(kPaperLatitudeDeg, 0.0);
  const ModelSpec spec = table2_model();
  struct Setup {
    std::string label;
    double g, h;
  };
  const std::vector<Setup> setups = {
      {"normal gravity 47.2 N, h = 0", g_local, 0.0},
      {"standard gravity, h = 0", physics::kStandardGravity, 0.0},
      {"normal gravity 47.2 N, h = 1 deg (constant tilt)", g_local, 1.0},
  };
  for (const auto& s : setups) {
    Table2Case c;
    c.label = s.label;
    c.g_mps2 = s.g;
    c.tilt_h_deg = s.h;
    c.fit = fit_points(table2_points(rows, s.g, s.h), spec);
    if (c.fit.ok()) {
      const auto& l = c.fit.lsq;
      Eigen::VectorXd a = Eigen::VectorXd::Zero(l.parameter_count);
      // g·cos h: the specific force on z at δ = 0.
      const double gz = physics::gravity_specific_force(physics::paper_table(s.h * physics::kDegToRad, 0.0), s.g).z();
      a[l.index("scale_z")] = gz;
      c.g_one_plus_scale = l.combination(a, gz);
      c.g_one_plus_scale.text = "g*cos(h)*(1 + scale_z)";
      Eigen::VectorXd b = Eigen::VectorXd::Zero(l.parameter_count);
      b[l.index("cross_zx")] = gz;
      c.g_cross_zx = l.combination(b);
      c.g_cross_zx.text = "g*cos(h)*cross_zx";
    }
    out.cases.push_back(c);
  }

  // The paper's parameters on the table (h = 0): a_z = f_z (1+δM) + s·μ33·f_x + Δa with f per unit
  // g = [−sin δ, 0, cos δ], and the sign s of μ33 that fits best (the paper does not fix the sense
  // of δ). per_g: the part proportional to g.
  const PaperTable2Fit& pp = out.paper;
  auto per_g = [&](const Table2Row& r, double sign) {
    const Eigen::Vector3d f =
        physics::gravity_specific_force(physics::paper_table(0.0, r.angle_deg * physics::kDegToRad), 1.0);
    return f.z() * (1 + pp.scale) + sign * pp.cross_zx * f.x();
  };
  auto rms_for = [&](double g, double sign) {
    double ss = 0;
    for (const auto& r : rows) {
      const double pred = g * per_g(r, sign) + pp.bias_mps2;
      ss += (r.a_z_mps2 - pred) * (r.a_z_mps2 - pred);
    }
    return std::sqrt(ss / static_cast<double>(rows.size()));
  };
  auto best_g_for = [&](double sign) {
    double num_ = 0, den = 0;
    for (const auto& r : rows) {
      const double c = per_g(r, sign);
      num_ += (r.a_z_mps2 - pp.bias_mps2) * c;
      den += c * c;
    }
    return num_ / den;
  };
  const double sign = rms_for(best_g_for(1.0), 1.0) <= rms_for(best_g_for(-1.0), -1.0) ? 1.0 : -1.0;
  out.paper_rms_normal_g = rms_for(g_local, sign);
  out.paper_best_g = best_g_for(sign);
  out.paper_rms_best_g = rms_for(out.paper_best_g, sign);
  if (!out.cases.empty() && out.cases[0].fit.ok()) {
    out.g_implied_by_paper_scale = out.cases[0].g_one_plus_scale.value / (1.0 + pp.scale);
    const auto& l = out.cases[0].fit.lsq;
    out.bias_scale_correlation = l.correlation()(l.index("bias_z"), l.index("scale_z"));
  }
  return out;
}

void print_table2_report(std::ostream& os, const Table2Reproduction& r) {
  os << "Paper Table 2 (MPU6050, Z channel, " << r.rows.size()
     << " angles) — batch LSQ with the error-model vocabulary\n"
     << "model: a_z = f_z + bias_z + scale_z*f_z + cross_zx*f_x + cross_zy*f_y,\n"
     << "       f = g*[-sin(d)cos(h), sin(h), cos(d)cos(h)]  (paper eq. (3)-(6) as specific force)\n\n";
  for (const auto& c : r.cases) {
    os << "=== " << c.label << ": g = " << number_text(c.g_mps2, 7, true) << " m/s^2, h = "
       << number_text(c.tilt_h_deg) << " deg\n";
    print_table(os, c.fit);
    if (c.fit.ok()) {
      os << "g-free: " << c.g_one_plus_scale << " m/s^2\n";
      os << "g-free: " << c.g_cross_zx << " m/s^2\n";
    }
    os << "\n";
  }
  if (r.cases.size() >= 2 && r.cases[0].fit.ok() && r.cases[1].fit.ok()) {
    const auto& a = r.cases[0].fit.lsq;
    const auto& b = r.cases[1].fit.lsq;
    char line[512];
    os << "=== Side by side (h = 0); the paper reports no uncertainty\n";
    std::snprintf(line, sizeof line, "%-10s %-13s %24s %24s %6s\n", "parameter", "paper",
                  "g(47.2 N) value +/- se", "standard g value +/- se", "unit");
    os << line;
    struct Row {
      const char* name;
      const char* paper_name;
      double paper;
      const char* unit;
    };
    const Row rows[] = {{"bias_z", "da_z", r.paper.bias_mps2, "m/s^2"},
                        {"scale_z", "dM", r.paper.scale, "1"},
                        {"cross_zx", "mu33", r.paper.cross_zx, "1"},
                        {"cross_zy", "mu34", r.paper.cross_zy, "1"}};
    for (const auto& row : rows) {
      const auto& pa = a.parameter(row.name);
      const auto& pb = b.parameter(row.name);
      auto cell = [](const estimation::ParameterEstimate& e) {
        return e.identifiable ? number_text(e.value, 5, true) + " +/- " + number_text(e.std_error, 5, true)
                              : std::string("NOT IDENTIFIABLE");
      };
      std::snprintf(line, sizeof line, "%-10s %-13s %24s %24s %6s\n", row.name,
                    (std::string(row.paper_name) + "=" + number_text(row.paper)).c_str(), cell(pa).c_str(),
                    cell(pb).c_str(), row.unit);
      os << line;
    }
    os << "bias_z/scale_z correlation: " << number_text(r.bias_scale_correlation, 4, true) << "\n";
    os << "paper parameters on the table: RMS residual " << number_text(r.paper_rms_normal_g, 4)
       << " m/s^2 with g(47.2 N); best g for them " << number_text(r.paper_best_g, 5, true)
       << " m/s^2 gives RMS " << number_text(r.paper_rms_best_g, 4) << " m/s^2 (our fit: "
       << number_text(r.cases[0].fit.residual_rms[2], 4) << " m/s^2)\n";
    os << "g implied by the paper's dM = " << number_text(r.paper.scale) << " and our g*(1+scale_z): "
       << number_text(r.g_implied_by_paper_scale, 5, true) << " m/s^2 (no place on Earth has it)\n";
  }
  if (!r.cases.empty() && r.cases[0].fit.ok()) {
    os << "\nresiduals (g at 47.2 N, h = 0):\n";
    for (const auto& res : r.cases[0].fit.residuals) {
      char line[128];
      std::snprintf(line, sizeof line, "  %5.1f deg  a_z %.5f  residual %+8.5f m/s^2\n",
                    r.rows[static_cast<std::size_t>(res.point)].angle_deg,
                    r.rows[static_cast<std::size_t>(res.point)].a_z_mps2, res.residual);
      os << line;
    }
  }
}

}  // namespace stend::batch_lsq::paper
