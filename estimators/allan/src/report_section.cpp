// allan's section of the run report (allan.json): per instrument the overlapping Allan deviation
// of each channel with its confidence band, the fitted noise model (drawn by this library's own
// model formula, NoiseModel::avar) and the slope lines, the coefficient table, and Kalibr's noise
// parameters.
#include "report_section.hpp"

#include "stend/allan/allan.hpp"
#include "stend/estimation/json_fields.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace stend::allan {

namespace {

using estimation::Cell;
using estimation::Emphasis;
using estimation::ReportSection;
using estimation::Row;
using estimation::Span;
using estimation::Table;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;
using nlohmann::json;

double num(const json& j, const char* key) { return estimation::number_field(j, key); }
double at(const json& a, std::size_t i) { return estimation::number_at(a, i); }
std::string str(const json& j, const char* key) { return estimation::text_field(j, key); }
std::string g(double v) { return estimation::report_number(v); }
std::string g3(double v) { return estimation::report_number(v, 3); }

// The fitted noise model of a channel's "model" document (missing coefficients as 0), for this
// library's own formula.
NoiseModel noise_model_of(const json& m, double rate_hz) {
  NoiseModel nm;
  nm.rate_hz = rate_hz;
  nm.lowpass_hz = num(m, "lowpass_hz");
  for (int j = 0; j < NoiseModel::kCoefficients; ++j) {
    Coefficient& c = nm.coefficients()[j];
    c.fitted = num(m.value(c.symbol, json::object()), "fitted");
    if (!std::isfinite(c.fitted)) c.fitted = 0.0;
  }
  return nm;
}

// The fitted model's ADEV over its τ range [s] (61 log-spaced τ, dashed in color c), and the slope
// lines of the identified coefficients: −½ (N/√τ), +½ (K·√(τ/3)); empty lines are left out.
std::vector<Series> model_series(const json& m, double rate_hz, const std::string& c) {
  const NoiseModel nm = noise_model_of(m, rate_hz);
  const json tr = m.value("tau_range_s", json::array());
  const double t0 = at(tr, 0), t1 = at(tr, 1);
  Series model{"", Style::kLine, {}, {}, {}, {}, c, true, 1.0};
  Series nline{"", Style::kLine, {}, {}, {}, {}, "#555", true, 0.6};
  Series kline{"", Style::kLine, {}, {}, {}, {}, "#999", true, 0.6};
  const json N = m.value("N", json::object()), K = m.value("K", json::object());
  if (std::isfinite(t0) && std::isfinite(t1) && t1 > t0) {
    for (int i = 0; i <= 60; ++i) {
      const double tau = t0 * std::pow(t1 / t0, i / 60.0);
      model.x.push_back(tau);
      model.y.push_back(std::sqrt(nm.avar(tau)));
      if (N.value("identified", false)) {
        nline.x.push_back(tau);
        nline.y.push_back(num(N, "value") / std::sqrt(tau));
      }
      if (K.value("identified", false)) {
        kline.x.push_back(tau);
        kline.y.push_back(num(K, "value") * std::sqrt(tau / 3.0));
      }
    }
  }
  std::vector<Series> out = {model};
  if (!nline.x.empty()) out.push_back(nline);
  if (!kline.x.empty()) out.push_back(kline);
  return out;
}

// Table row of a channel's N, K, B and Gauss–Markov bias (σ, τc): each coefficient's verdict —
// value ± σ when identified, else the upper bound, or failed.
Row coefficient_row(const json& ch, const json& m) {
  auto cell = [](const json& coef) {
    const std::string v = coef.value("verdict", coef.value("identified", false) ? "identified" : "upper_bound");
    if (v == "identified") return fmt::format("{} ± {}", g3(num(coef, "value")), g3(num(coef, "sigma")));
    if (v == "failed") return std::string("failed");
    const double ub = num(coef, "upper_bound");
    return std::isfinite(ub) ? fmt::format("≤ {} (not identified)", g3(ub)) : std::string("not identified");
  };
  const json N = m.value("N", json::object()), K = m.value("K", json::object()), B = m.value("B", json::object());
  const json G = m.value("G", json::object()), Tc = m.value("Tc", json::object());
  const std::string gm = G.value("identified", false) ? cell(G) + ", τc " + cell(Tc) + " s" : cell(G);
  return Row{{str(ch, "channel"), cell(N), cell(K), cell(B), gm,
              str(N, "unit") + ", " + str(K, "unit") + ", " + str(B, "unit")}};
}

// One channel into the instrument's plot (confidence band, points, model curves in color c) and
// its table row (or the model's failure).
void add_channel(const json& ch, const std::string& c, Plot& p, Table& table) {
  p.y_label = "Allan deviation [" + str(ch, "unit") + "]";
  Series band{"", Style::kBand, {}, {}, {}, {}, c, false, 0.2};
  Series pts{str(ch, "channel"), Style::kPoints, {}, {}, {}, {}, c, false, 1.0};
  for (const auto& pt : ch.value("points", json::array())) {
    band.x.push_back(num(pt, "tau_s"));
    band.y_lo.push_back(num(pt, "adev_lo"));
    band.y_hi.push_back(num(pt, "adev_hi"));
    pts.x.push_back(num(pt, "tau_s"));
    pts.y.push_back(num(pt, "adev"));
  }
  p.series.push_back(band);
  p.series.push_back(pts);
  const json m = ch.value("model", json::object());
  if (!m.value("ok", false)) {
    table.rows.push_back(
        Row{{str(ch, "channel"), Cell{"model fit failed: " + str(m, "message"), 6, Emphasis::kFailure}}});
    return;
  }
  for (auto& s : model_series(m, num(ch, "rate_hz"), c)) p.series.push_back(std::move(s));
  table.rows.push_back(coefficient_row(ch, m));
}

// The Allan plot and coefficient table of one instrument; nothing when it has no channel.
void add_instrument(ReportSection& s, const json& al, const std::string& inst) {
  Plot p;
  p.x_log = p.y_log = true;
  p.width = 760;
  p.height = 440;
  p.title = inst + " Allan deviation";
  p.x_label = "averaging time τ [s]";
  Table table;
  table.header = {"channel", "N (white)", "K (random walk)", "B (bias instability)",
                  "Gauss–Markov bias σ (unit of B)", "units N, K, B"};
  std::size_t color = 0;
  for (const auto& ch : al.value("channels", json::array()))
    if (str(ch, "instrument") == inst) add_channel(ch, estimation::figure::palette(color++), p, table);
  if (color == 0) return;
  s.add(p, "Overlapping Allan deviation with its confidence band (shaded), the fitted noise model (dashed, same "
           "color) and the slope lines of identified coefficients (grey dashed: −½ white noise N/√τ, light grey: "
           "+½ random walk K·√(τ/3)).");
  s.add(std::move(table));
}

// Whether the results hold a channel of `inst` ("accelerometer" | "gyroscope"): a gyro-only or an
// accelerometer-only recording has the other's none.
bool has_channels(const json& al, const std::string& inst) {
  const json channels = al.value("channels", json::array());
  return std::any_of(channels.begin(), channels.end(), [&](const json& ch) { return str(ch, "instrument") == inst; });
}

// The Kalibr noise parameters (with identification and upper-bound flags) of the instruments the
// results hold; an absent instrument is named as absent, never given numbers.
estimation::Paragraph kalibr_paragraph(const json& al) {
  const json& kb = al["kalibr"];
  std::string text = "Kalibr:";
  for (const std::string instrument : {"accelerometer", "gyroscope"}) {
    if (!has_channels(al, instrument)) {
      text += " no " + instrument + " in the recording,";
      continue;
    }
    text += fmt::format(" {0}_noise_density {1}{2}, {0}_random_walk {3}{4},", instrument,
                        g3(num(kb, (instrument + "_noise_density").c_str())),
                        kb.value(instrument + "_noise_identified", false) ? "" : " (not identified)",
                        g3(num(kb, (instrument + "_random_walk").c_str())),
                        kb.value(instrument + "_random_walk_is_upper_bound", false) ? " (UPPER BOUND)" : "");
  }
  text += fmt::format(" update_rate {} Hz (", g(num(kb, "update_rate")));
  return {{Span{text}, Span{"stend export RUN --to kalibr", Span::Kind::kCode}, Span{")."}}};
}

}  // namespace

ReportSection report_section(const estimation::FitResult& result) {
  const json& al = result.document;
  ReportSection s;
  s.heading = "Noise — Allan deviation";
  s.file = result.results_file;
  s.topic = ReportSection::Topic::kNoise;
  s.add_text(g(num(al, "samples")) + " samples at " + g(num(al, "rate_hz")) + " Hz (" + str(al, "source") + ").");
  for (const auto& w : al.value("warnings", json::array()))
    if (w.is_string()) s.add_text("warning: " + w.get<std::string>(), Emphasis::kWarning);
  for (const auto& n : al.value("notes", json::array()))
    if (n.is_string()) s.add_text("note: " + n.get<std::string>());
  for (const char* inst : {"accelerometer", "gyroscope"}) add_instrument(s, al, inst);
  if (al.contains("kalibr")) s.add(kalibr_paragraph(al));
  return s;
}

}  // namespace stend::allan
