// batch_lsq's section of the run report: the fit's size and conditioning, the parameter table,
// the aliased groups and warnings, and the residual plots of the static points (fit.json, schema
// stend.fit/1).
#include "report_section.hpp"

#include "stend/estimation/fit_report.hpp"
#include "stend/estimation/json_fields.hpp"

#include <nlohmann/json.hpp>

namespace stend::batch_lsq {

namespace {

using estimation::report_number;
using nlohmann::json;

double num(const json& j, const char* key) { return estimation::number_field(j, key); }
std::string str(const json& j, const char* key) { return estimation::text_field(j, key); }

// "<instrument> model, terms: …. Observations k = …, parameters p = …, rank …, dof …, σ = … mg,
// condition number … (identified subspace …)."
std::string solution_text(const json& fit) {
  const json sol = fit.value("solution", json::object());
  const json model = fit.value("model", json::object());
  std::string terms;
  for (const auto& t : model.value("terms", json::array())) terms += (terms.empty() ? "" : ", ") + str(t, "kind");
  const std::string residual_unit = fit.value("units", json::object()).value("residual", "");
  const estimation::DisplayUnit sigma_unit =
      residual_unit.empty() ? estimation::DisplayUnit{1.0, ""} : estimation::display_unit(residual_unit);
  return str(model, "instrument") + " model, terms: " + terms + ". Observations k = " +
         report_number(num(sol, "observations")) + ", parameters p = " + report_number(num(sol, "parameters")) +
         ", rank " + report_number(num(sol, "rank")) + ", dof " + report_number(num(sol, "dof")) + ", σ = " +
         report_number(num(sol, "sigma") * sigma_unit.scale) + " " + sigma_unit.unit + ", condition number " +
         report_number(num(sol, "condition_number")) + " (identified subspace " +
         report_number(num(sol, "condition_number_identified")) + ").";
}

}  // namespace

estimation::ReportSection report_section(const estimation::FitResult& result) {
  const estimation::FitSummary& s = result.summary;
  const json& fit = result.document;
  estimation::ReportSection section;
  section.heading = "Error-model fit — " + s.estimator + " " + s.version;
  section.file = result.results_file;
  section.topic = estimation::ReportSection::Topic::kErrorModel;
  if (!s.ok()) {
    section.add(estimation::failure_paragraph("FIT FAILED", s.message));
    return section;
  }
  if (fit.contains("solution")) section.add_text(solution_text(fit));
  section.add(estimation::parameter_table(s));
  section.append(estimation::fit_notes(fit));
  section.append(estimation::static_point_figures(fit, s.estimator));
  return section;
}

}  // namespace stend::batch_lsq
