// `stend deviations FILE --tau0 S [--phase]` — the frequency-stability deviations of a plain time
// series (one value per line, or one column): Stable32's and allantools' input, a clock's phase or
// frequency data, one gyro or accelerometer axis exported from elsewhere. The same DeviationStream,
// noise identification, EDF and intervals as `stend fit … --model allan.yaml` uses per channel of a
// recording; nothing is written but what --json prints.
#include "commands.hpp"

#include "stend/allan/deviation_report.hpp"
#include "stend/io/series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace stend::cli {

namespace {



std::vector<std::string> kind_names() {
  std::vector<std::string> names;
  for (auto k : allan::kAllDeviationKinds) names.emplace_back(allan::to_string(k));
  return names;
}

allan::DeviationRequest request_of(const DeviationsArgs& a) {
  allan::DeviationRequest r;
  for (const std::string& name : a.kinds.empty() ? kind_names() : a.kinds)
    for (auto k : allan::kAllDeviationKinds)
      if (name == allan::to_string(k) && std::find(r.kinds.begin(), r.kinds.end(), k) == r.kinds.end())
        r.kinds.push_back(k);
  for (auto t : {allan::TauSpacing::kOctave, allan::TauSpacing::kLog, allan::TauSpacing::kAll})
    if (a.tau == allan::to_string(t)) r.tau = t;
  return r;
}

// Why the series cannot be characterised (empty: it can): too short for any averaging time, or
// constant — frequency values all equal (phase: a straight line), so every deviation is 0 and no
// noise type can be told.
std::string unusable(const std::vector<double>& v, bool phase, const allan::ChannelDeviations& d) {
  const std::size_t frequency_values = phase ? (v.empty() ? 0 : v.size() - 1) : v.size();
  const bool any = std::any_of(d.kinds.begin(), d.kinds.end(), [](const auto& k) { return !k.second.empty(); });
  if (!any)
    return fmt::format("too short: {} {} value(s) ({} frequency value(s)); the shortest averaging time needs 3 "
                       "phase points",
                       v.size(), phase ? "phase" : "frequency", frequency_values);
  bool constant = true;
  for (std::size_t i = phase ? 2 : 1; constant && i < v.size(); ++i)
    constant = phase ? v[i] - v[i - 1] == v[1] - v[0] : v[i] == v[0];
  if (constant)
    return phase ? "the phase is a straight line (constant frequency): every deviation is 0, there is no noise to "
                   "characterise"
                 : "the values are all equal: every deviation is 0, there is no noise to characterise";
  return {};
}

// Per kind, Stable32's run table: τ, m, terms, α, EDF, the interval and the value.
void print_points(std::FILE* out, const allan::ChannelDeviations& d) {
  for (const auto& [kind, points] : d.kinds) {
    fmt::print(out, "\n{} [{}{}]\n", allan::to_string(kind), d.channel.unit,
               kind == allan::DeviationKind::kTdev ? "*s" : "");
    fmt::print(out, "  {:>12} {:>10} {:>10} {:>5} {:>10} {:>12} {:>12} {:>12}\n", "tau [s]", "m", "terms", "alpha",
               "EDF", "min sigma", "value", "max sigma");
    for (const auto& p : points)
      fmt::print(out, "  {:>12.6g} {:>10} {:>10} {:>5} {:>10.4g} {:>12.5e} {:>12.5e} {:>12.5e}\n", p.tau_s, p.m, p.terms,
                 p.alpha, p.edf, p.lo, p.dev, p.hi);
  }
}

}  // namespace

Outcome deviations_of(const io::SeriesValues& series, const DeviationsArgs& a) {
  if (a.tau0_s <= 0 && a.rate_hz <= 0)
    throw Refusal(ExitCode::kUsage, "error: deviations: give --tau0 S or --rate-hz HZ (the spacing of the values)");
  const double rate_hz = a.rate_hz > 0 ? a.rate_hz : 1.0 / a.tau0_s;
  allan::AllanOptions options;
  options.max_m = a.max_m;
  options.confidence = a.confidence;
  // Phase in seconds gives deviations of fractional frequency (unit 1), as frequency data do.
  const allan::ChannelInfo channel{fmt::format("column {}", a.column.column), allan::Instrument::kOther,
                                   a.unit.empty() ? "1" : a.unit};
  const auto request = request_of(a);
  const std::vector<double>& v = series.values;
  const allan::ChannelDeviations d = a.phase ? allan::phase_deviations(v.data(), v.size(), rate_hz, channel, request, options)
                                             : allan::channel_deviations(v.data(), v.size(), rate_hz, channel, request, options);
  const double tau0 = 1.0 / rate_hz;
  fmt::print(human(), "series:     {} (column {}, {} {} value(s) from line {}), tau0 {:.6g} s\n", a.file,
             a.column.column, v.size(), a.phase ? "phase" : "frequency", series.first_line, tau0);
  nlohmann::json doc = {{"file", a.file}, {"column", a.column.column}, {"input", a.phase ? "phase" : "frequency"},
                        {"values", v.size()}, {"tau0_s", tau0}};
  if (const std::string why = unusable(v, a.phase, d); !why.empty()) {
    fmt::print(stderr, "deviations failed: {}\n", why);
    doc["ok"] = false;
    doc["reason"] = why;
    return {ExitCode::kFitFailed, doc};
  }
  allan::write_deviation_table(human_stream(), {d});
  print_points(human(), d);
  doc["ok"] = true;
  allan::add_deviations_json(doc, {d}, request.tau);
  return {ExitCode::kOk, doc};
}

Outcome run_deviations(const DeviationsArgs& a) {
  if (a.tau0_s <= 0 && a.rate_hz <= 0) return deviations_of({}, a);  // refused before reading
  return deviations_of(io::read_series(a.file, a.column), a);
}

void add_deviations_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand(
      "deviations", "Frequency-stability deviations (ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV) of a plain time "
                    "series: phase or frequency data, one value per line or one column (Stable32's input)");
  static DeviationsArgs a;
  sub->add_option("file", a.file, "Text file: one value per line, or columns separated by spaces, tabs, commas or "
                                  "semicolons; lines starting with # or % are skipped")
      ->required();
  auto* tau0 = sub->add_option("--tau0", a.tau0_s, "Time between values [s]")->check(above(0.0));
  auto* rate = sub->add_option("--rate-hz", a.rate_hz, "Values per second (instead of --tau0)")->check(above(0.0));
  tau0->excludes(rate);
  rate->excludes(tau0);
  sub->add_flag("--phase", a.phase, "The values are phase (time error) [s], not frequency or rate");
  sub->add_option("--column", a.column.column, "The column to read: its number (1 = the first) or its name on the "
                                               "column-name line (a first line whose field is text is taken as one)");
  sub->add_option("--skip-lines", a.column.skip_lines, "Lines before the column names or the data (a logger's header)");
  sub->add_option("--kinds", a.kinds, "Deviations to compute (default: all)")
      ->delimiter(',')
      ->check(CLI::IsMember(kind_names()));
  sub->add_option("--tau", a.tau, "Averaging times: octave (m = 1, 2, 4, …), log (10 per decade) or all (every m: "
                                  "O(N^2), for short series)")
      ->check(CLI::IsMember({allan::to_string(allan::TauSpacing::kOctave), allan::to_string(allan::TauSpacing::kLog),
                             allan::to_string(allan::TauSpacing::kAll)}));
  sub->add_option("--max-m", a.max_m, "Largest averaging factor [values]")->check(at_least(1.0));
  sub->add_option("--confidence", a.confidence, "Two-sided level of the intervals (default: one sigma, 0.6827)")
      ->check(strictly_within(0.0, 1.0));
  sub->add_option("--unit", a.unit, "Unit of the deviations: the frequency values' unit, e.g. deg/s for a gyro axis "
                                    "(default 1: fractional frequency, as from phase in seconds)");
  add_json_flag(sub, "the deviations with tau, m, terms, EDF, interval and noise type per point");
  out.push_back({sub, [] {
                   const Outcome o = run_deviations(a);
                   print_json(o.doc);
                   return o.code;
                 }});
}

}  // namespace stend::cli
