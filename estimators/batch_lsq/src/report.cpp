// Text table and JSON ("stend.fit/1") output of a batch_lsq fit.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>

#include "stend/batch_lsq/batch_lsq.hpp"

namespace stend::batch_lsq {

namespace {

// %.<digits>g, or %.<digits>f when fixed.
std::string num(double v, int digits = 6, bool fixed = false) {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  if (fixed)
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  else
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

nlohmann::ordered_json number_or_null(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v;
}

std::string term_text(const model::TermSpec& t) {
  std::string s = model::term_name(t.kind);
  if (t.kind == model::TermKind::kBiasTemperature || t.kind == model::TermKind::kScaleTemperature)
    s += "(order " + std::to_string(t.order) + ", T0 " + num(t.reference_c) + " degC)";
  return s;
}

nlohmann::ordered_json combination_json(const estimation::Combination& c,
                                 const std::vector<estimation::ParameterEstimate>& params) {
  nlohmann::ordered_json coeffs = nlohmann::ordered_json::object();
  for (const auto& [idx, v] : c.coefficients) coeffs[params[static_cast<std::size_t>(idx)].name] = v;
  return {{"text", c.text},
          {"coefficients", coeffs},
          {"value", number_or_null(c.value)},
          {"std_error", number_or_null(c.std_error)},
          {"interval", {number_or_null(c.lower), number_or_null(c.upper)}}};
}

}  // namespace

void print_table(std::ostream& os, const FitResult& fr) {
  const ModelSpec& s = fr.spec;
  const processing::StaticExtractionSettings& ex = s.processing.extraction;
  os << "batch_lsq " << kEstimatorVersion << " — " << estimation::instrument_name(s.model.instrument)
     << ", axes [";
  for (std::size_t i = 0; i < s.axes.size(); ++i) os << (i ? ", " : "") << estimation::axis_name(s.axes[i]);
  os << "], terms:";
  for (const auto& t : s.model.terms) os << " " << term_text(t);
  os << "\n";
  if (!fr.recording_dir.empty())
    os << "recording: " << fr.recording_dir << " (experiment '" << fr.experiment_name
       << "', status " << fr.recording_status << ")\n";
  if (!fr.extracted)
    os << "static extraction: none (the points were given directly); weighting "
       << estimation::weighting_name(s.weighting) << "\n";
  else if (ex.filter == processing::Filter::kNone)
    os << "static extraction: plain mean (no filter), settle " << num(ex.settle_s)
       << " s discarded at each end; weighting " << estimation::weighting_name(s.weighting) << "\n";
  else
    os << "static extraction: Butterworth order " << ex.filter_order << ", cutoff "
     << num(ex.cutoff_hz) << " Hz, " << (ex.zero_phase ? "zero-phase" : "causal")
     << ", settle " << num(ex.settle_s) << " s discarded at each end; weighting "
     << estimation::weighting_name(s.weighting) << "\n";
  if (!fr.ok) {
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
    os << "  " << estimation::axis_name(a) << " " << num(fr.residual_rms[a], 4) << " " << fr.unit << " ("
       << num(fr.residual_rms_display[a], 4) << " " << fr.display_unit << ")";
  os << "\nresidual standard deviation (dof-corrected): " << num(std::sqrt(fr.lsq.sigma2), 4)
     << " " << fr.unit << "\n";
  for (const auto& n : fr.notes) os << "note: " << n << "\n";
}

std::ostream& operator<<(std::ostream& os, const FitResult& fit) {
  print_table(os, fit);
  return os;
}

namespace {

using ojson = nlohmann::ordered_json;

// "model": instrument, fitted axes, terms (temperature terms with order and T0 [°C]), source.
ojson model_json(const ModelSpec& s) {
  ojson terms = ojson::array();
  for (const auto& t : s.model.terms) {
    ojson tj = {{"kind", model::term_name(t.kind)}};
    if (t.kind == model::TermKind::kBiasTemperature || t.kind == model::TermKind::kScaleTemperature) {
      tj["order"] = t.order;
      tj["reference_c"] = t.reference_c;
    }
    terms.push_back(tj);
  }
  ojson axes = ojson::array();
  for (int a : s.axes) axes.push_back(std::string(1, estimation::axis_name(a)));
  return {{"instrument", estimation::instrument_name(s.model.instrument)},
          {"axes", axes},
          {"terms", terms},
          {"source", s.source}};
}

// "extraction": whether it ran and its settings (filter, order, cutoff [Hz], settle [s], phase, kinds).
ojson extraction_json(const FitResult& fr) {
  const processing::StaticExtractionSettings& ex = fr.spec.processing.extraction;
  return {{"applied", fr.extracted},
          {"filter", processing::filter_name(ex.filter)},
          {"order", ex.filter_order},
          {"cutoff_hz", ex.cutoff_hz},
          {"settle_s", ex.settle_s},
          {"zero_phase", ex.zero_phase},
          {"segment_kinds", fr.spec.processing.segment_kinds}};
}

// "points": each static point's span [s], samples, measured mean and its standard error, true
// input and temperature [°C].
ojson points_json(const std::vector<StaticPoint>& points) {
  ojson pts = ojson::array();
  for (const auto& p : points) {
    ojson m = ojson::array(), se = ojson::array(), in = ojson::array();
    for (int a = 0; a < 3; ++a) {
      m.push_back(number_or_null(p.measured[a]));
      se.push_back(number_or_null(p.measured_std_error[a]));
      in.push_back(number_or_null(p.stimulus.input[a]));
    }
    pts.push_back({{"segment", p.segment_id},
                   {"label", p.label},
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

// "solution": method, counts, RSS, σ, confidence and quantile, condition numbers.
ojson solution_json(const estimation::LsqResult& r) {
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

// "parameters": value, standard error and interval of each identifiable parameter; null and the
// reason for the others.
ojson parameters_json(const FitResult& fr) {
  ojson params = ojson::array();
  for (std::size_t i = 0; i < fr.lsq.parameters.size(); ++i) {
    const auto& e = fr.lsq.parameters[i];
    ojson pj = {{"name", e.name}, {"unit", e.unit}, {"index", fr.param_index[i]}, {"identifiable", e.identifiable}};
    if (e.identifiable) {
      pj["value"] = e.value;
      pj["std_error"] = e.std_error;
      pj["interval"] = {e.lower, e.upper};
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

// "correlation": the parameters' correlation matrix, row by row (null where undefined).
ojson correlation_json(const estimation::LsqResult& r) {
  ojson corr = ojson::array();
  const Eigen::MatrixXd c = r.correlation();
  for (Eigen::Index a = 0; a < c.rows(); ++a) {
    ojson row = ojson::array();
    for (Eigen::Index b = 0; b < c.cols(); ++b) row.push_back(number_or_null(c(a, b)));
    corr.push_back(row);
  }
  return corr;
}

// "aliases": groups of parameters that only combinations of are identified.
ojson aliases_json(const estimation::LsqResult& r) {
  ojson aliases = ojson::array();
  for (const auto& g : r.aliases) {
    ojson names = ojson::array();
    for (int idx : g.parameters) names.push_back(r.parameters[static_cast<std::size_t>(idx)].name);
    ojson comb = ojson::array();
    for (const auto& cb : g.identified) comb.push_back(combination_json(cb, r.parameters));
    aliases.push_back({{"parameters", names}, {"null_dimension", g.null_dimension}, {"identified_combinations", comb}});
  }
  return aliases;
}

// "residuals": RMS per axis (residual unit and display unit) and every row.
ojson residuals_json(const FitResult& fr) {
  ojson rms = ojson::object(), rms_d = ojson::object();
  for (int a : fr.spec.axes) {
    rms[std::string(1, estimation::axis_name(a))] = fr.residual_rms[a];
    rms_d[std::string(1, estimation::axis_name(a))] = fr.residual_rms_display[a];
  }
  ojson res = ojson::array();
  for (const auto& x : fr.residuals)
    res.push_back({{"point", x.point},
                   {"axis", std::string(1, estimation::axis_name(x.axis))},
                   {"observed", x.observed},
                   {"fitted", x.fitted},
                   {"residual", x.residual}});
  return {{"rms", rms}, {"rms_display", rms_d}, {"rows", res}};
}

}  // namespace

std::string to_json(const FitResult& fr, int indent) {
  ojson j;
  j["schema"] = kFitSchema;
  j["estimator"] = {{"name", kEstimatorName}, {"version", kEstimatorVersion}};
  j["status"] = fr.ok ? "ok" : "failed";
  j["message"] = fr.message;
  j["recording"] = {{"dir", fr.recording_dir}, {"experiment", fr.experiment_name}, {"status", fr.recording_status}};
  j["model"] = model_json(fr.spec);
  j["extraction"] = extraction_json(fr);
  j["weighting"] = estimation::weighting_name(fr.spec.weighting);
  j["units"] = {{"residual", fr.unit}, {"residual_display", fr.display_unit}};
  j["notes"] = fr.notes;
  j["excluded_parameters"] = fr.excluded;
  j["points"] = points_json(fr.points);
  if (!fr.ok) return j.dump(indent);
  j["solution"] = solution_json(fr.lsq);
  j["parameters"] = parameters_json(fr);
  j["correlation"] = correlation_json(fr.lsq);
  j["aliases"] = aliases_json(fr.lsq);
  j["warnings"] = fr.lsq.warnings;
  j["residuals"] = residuals_json(fr);
  return j.dump(indent);
}

void write_json(const std::filesystem::path& file, const FitResult& fit) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error("cannot write fit JSON '" + file.string() + "'");
  out << to_json(fit) << "\n";
  if (!out) throw std::runtime_error("error while writing fit JSON '" + file.string() + "'");
}

}  // namespace stend::batch_lsq
