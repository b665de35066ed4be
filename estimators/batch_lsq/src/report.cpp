// Text table and JSON ("stend.fit/1") output of a batch_lsq fit.
#include <cmath>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>

#include "stend/batch_lsq/batch_lsq.hpp"
#include "stend/recording/files.hpp"

namespace stend::batch_lsq {

namespace {

using estimation::axis_name;
using estimation::instrument_name;
using estimation::number_text;
using estimation::weighting_name;
using json = nlohmann::ordered_json;

json number_or_null(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v;
}

std::string axis_text(int axis) { return std::string(1, axis_name(axis)); }

std::string term_text(const model::TermSpec& t) {
  std::string s = model::term_name(t.kind);
  if (model::is_temperature_polynomial(t.kind))
    s += "(order " + std::to_string(t.order) + ", T0 " + number_text(t.reference_c) + " degC)";
  return s;
}

// The extraction line of the text table: none, a plain mean, or the Butterworth filter.
std::string extraction_text(const FitResult& fr) {
  const ModelSpec& s = fr.spec;
  const processing::StaticExtractionSettings& ex = s.processing.extraction;
  const std::string weighting = std::string("; weighting ") + weighting_name(s.weighting);
  if (!fr.extracted) return "static extraction: none (the points were given directly)" + weighting;
  if (ex.filter == processing::Filter::kNone)
    return "static extraction: plain mean (no filter), settle " + number_text(ex.settle_s) +
           " s discarded at each end" + weighting;
  return "static extraction: Butterworth order " + std::to_string(ex.filter_order) + ", cutoff " +
         number_text(ex.cutoff_hz) + " Hz, " + (ex.zero_phase ? "zero-phase" : "causal") + ", settle " +
         number_text(ex.settle_s) + " s discarded at each end" + weighting;
}

// --- JSON sections of "stend.fit/1" ------------------------------------------------------------

// "model": instrument, fitted axes, terms (temperature polynomials with order and T0 [degC]).
json model_json(const ModelSpec& s) {
  json terms = json::array();
  for (const auto& t : s.model.terms) {
    json tj = {{"kind", model::term_name(t.kind)}};
    if (model::is_temperature_polynomial(t.kind)) {
      tj["order"] = t.order;
      tj["reference_c"] = t.reference_c;
    }
    terms.push_back(tj);
  }
  json axes = json::array();
  for (int a : s.axes) axes.push_back(axis_text(a));
  return {{"instrument", instrument_name(s.model.instrument)}, {"axes", axes}, {"terms", terms}, {"source", s.source}};
}

// "extraction": whether applied, the filter, its order, cutoff [Hz], settle time [s], phase.
json extraction_json(const FitResult& fr) {
  const processing::ProcessingOptions& po = fr.spec.processing;
  const processing::StaticExtractionSettings& ex = po.extraction;
  return {{"applied", fr.extracted},
          {"filter", processing::filter_name(ex.filter)},
          {"order", ex.filter_order},
          {"cutoff_hz", ex.cutoff_hz},
          {"settle_s", ex.settle_s},
          {"zero_phase", ex.zero_phase},
          {"segment_kinds", po.segment_kinds}};
}

// "points": each static point's segment, times [s], mean reading, its standard error and the
// true input (instrument unit, x y z), and its temperature [degC].
json points_json(const std::vector<processing::StaticPoint>& points, model::Instrument instrument) {
  json pts = json::array();
  for (const auto& p : points) {
    const processing::AxesValue& reading = p.axes(instrument);
    json m = json::array(), se = json::array(), in = json::array();
    for (int a = 0; a < 3; ++a) {
      m.push_back(number_or_null(reading.mean[a]));
      se.push_back(number_or_null(reading.std_error[a]));
      in.push_back(number_or_null(p.stimulus.input[a]));
    }
    pts.push_back({{"segment", p.segment.id},
                   {"label", processing::label(p.segment)},
                   {"t_start_s", p.t_start_s},
                   {"t_end_s", p.t_end_s},
                   {"samples", p.samples_used},
                   {"measured", m},
                   {"measured_std_error", se},
                   {"true_input", in},
                   {"temperature_c", number_or_null(p.stimulus.temperature_c)}});
  }
  return pts;
}

// "solution": method, sizes, RSS, σ, confidence, quantile and condition numbers.
json solution_json(const estimation::LsqResult& r) {
  return {{"method", r.method == estimation::LsqMethod::kQr ? "qr" : "svd"},
          {"observations", r.observations},
          {"parameters", r.parameter_count},
          {"rank", r.rank},
          {"dof", r.dof},
          {"rss", r.rss},
          {"sigma", std::sqrt(r.sigma2)},
          {"confidence", r.confidence},
          {"quantile", r.quantile},
          {"condition_number", number_or_null(r.condition_number)},
          {"condition_number_identified", number_or_null(r.condition_number_identified)}};
}

// "parameters": value, standard error and interval of each identified one; null and the reason
// for the others.
json parameters_json(const FitResult& fr) {
  json params = json::array();
  for (std::size_t i = 0; i < fr.lsq.parameters.size(); ++i) {
    const auto& e = fr.lsq.parameters[i];
    json pj = {{"name", e.name}, {"unit", e.unit}, {"index", fr.param_index[i]}, {"identifiable", e.identifiable}};
    pj["verdict"] = estimation::to_string(e.judged());
    pj["tolerance"] = number_or_null(e.tolerance);
    if (e.identifiable) {
      pj["value"] = e.value;
      pj["std_error"] = e.std_error;
      pj["interval"] = {e.lower, e.upper};
      if (e.judged() == estimation::Verdict::kImprecise) pj["reason"] = e.reason;
    } else {
      pj["value"] = nullptr;
      pj["std_error"] = nullptr;
      pj["interval"] = nullptr;
      pj["reason"] = e.reason;
    }
    params.push_back(pj);
  }
  return params;
}

// "correlation": the parameters' correlation matrix, rows (null where not identified).
json correlation_json(const estimation::LsqResult& r) {
  json corr = json::array();
  const Eigen::MatrixXd c = r.correlation();
  for (Eigen::Index a = 0; a < c.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < c.cols(); ++b) row.push_back(number_or_null(c(a, b)));
    corr.push_back(row);
  }
  return corr;
}

json combination_json(const estimation::Combination& c, const std::vector<estimation::ParameterEstimate>& params) {
  json coeffs = json::object();
  for (const auto& [idx, v] : c.coefficients) coeffs[params[static_cast<std::size_t>(idx)].name] = v;
  return {{"text", c.text},
          {"coefficients", coeffs},
          {"value", number_or_null(c.value)},
          {"std_error", number_or_null(c.std_error)},
          {"interval", {number_or_null(c.lower), number_or_null(c.upper)}}};
}

// "aliases": each aliased group's parameters, null-space dimension and identified combinations.
json aliases_json(const estimation::LsqResult& r) {
  json aliases = json::array();
  for (const auto& g : r.aliases) {
    json names = json::array();
    for (int idx : g.parameters) names.push_back(r.parameters[static_cast<std::size_t>(idx)].name);
    json comb = json::array();
    for (const auto& cb : g.identified) comb.push_back(combination_json(cb, r.parameters));
    aliases.push_back({{"parameters", names}, {"null_dimension", g.null_dimension}, {"identified_combinations", comb}});
  }
  return aliases;
}

// "residuals": RMS per fitted axis (instrument and display unit) and every residual row.
json residuals_json(const FitResult& fr) {
  json rms = json::object(), rms_d = json::object();
  for (int a : fr.spec.axes) {
    rms[axis_text(a)] = fr.residual_rms[a];
    rms_d[axis_text(a)] = fr.residual_rms_display[a];
  }
  json res = json::array();
  for (const auto& x : fr.residuals)
    res.push_back({{"point", x.point},
                   {"axis", axis_text(x.axis)},
                   {"observed", x.observed},
                   {"fitted", x.fitted},
                   {"residual", x.residual}});
  return {{"rms", rms}, {"rms_display", rms_d}, {"rows", res}};
}

}  // namespace

void print_table(std::ostream& os, const FitResult& fr) {
  const ModelSpec& s = fr.spec;
  os << "batch_lsq " << kEstimatorVersion << " — " << instrument_name(s.model.instrument)
     << ", axes [";
  for (std::size_t i = 0; i < s.axes.size(); ++i) os << (i ? ", " : "") << axis_name(s.axes[i]);
  os << "], terms:";
  for (const auto& t : s.model.terms) os << " " << term_text(t);
  os << "\n";
  if (!fr.recording_dir.empty())
    os << "recording: " << fr.recording_dir << " (experiment '" << fr.experiment_name
       << "', status " << fr.recording_status << ")\n";
  os << extraction_text(fr) << "\n";
  if (!fr.ok()) {
    os << "FIT FAILED: " << fr.message << "\n";
    for (const auto& n : fr.notes) os << "note: " << n << "\n";
    return;
  }
  os << "points: " << fr.points.size() << " orientations x " << s.axes.size() << " axes = "
     << fr.lsq.observations << " equations, " << fr.lsq.parameter_count << " parameters, rank "
     << fr.lsq.rank << ", dof " << fr.lsq.dof << "\n";
  os << fr.lsq;
  if (!fr.excluded.empty()) {
    os << "not in this fit (cannot affect the fitted axes):";
    for (const auto& e : fr.excluded) os << " " << e;
    os << "\n";
  }
  os << "residual RMS:";
  for (int a : s.axes)
    os << "  " << axis_name(a) << " " << number_text(fr.residual_rms[a], 4) << " " << fr.unit << " ("
       << number_text(fr.residual_rms_display[a], 4) << " " << fr.display_unit << ")";
  os << "\nresidual standard deviation (dof-corrected): " << number_text(std::sqrt(fr.lsq.sigma2), 4)
     << " " << fr.unit << "\n";
  for (const auto& n : fr.notes) os << "note: " << n << "\n";
}

std::ostream& operator<<(std::ostream& os, const FitResult& fit) {
  print_table(os, fit);
  return os;
}

std::string to_json(const FitResult& fr, int indent) {
  json j;
  j["schema"] = kFitSchema;
  j["estimator"] = {{"name", kEstimatorName}, {"version", kEstimatorVersion}};
  j["status"] = fr.ok() ? "ok" : "failed";
  j["message"] = fr.message;
  j["recording"] = {{"dir", fr.recording_dir}, {"experiment", fr.experiment_name}, {"status", fr.recording_status}};
  j["model"] = model_json(fr.spec);
  j["extraction"] = extraction_json(fr);
  j["weighting"] = weighting_name(fr.spec.weighting);
  j["units"] = {{"residual", fr.unit}, {"residual_display", fr.display_unit}};
  j["notes"] = fr.notes;
  j["excluded_parameters"] = fr.excluded;
  j["points"] = points_json(fr.points, fr.spec.model.instrument);
  if (!fr.ok()) return j.dump(indent);
  j["solution"] = solution_json(fr.lsq);
  j["parameters"] = parameters_json(fr);
  j["correlation"] = correlation_json(fr.lsq);
  j["aliases"] = aliases_json(fr.lsq);
  j["warnings"] = fr.lsq.warnings;
  j["residuals"] = residuals_json(fr);
  return j.dump(indent);
}

void write_json(const std::filesystem::path& file, const FitResult& fit) { write_file_atomic(file, to_json(fit) + "\n"); }

}  // namespace stend::batch_lsq
