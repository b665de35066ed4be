// Internal: the error model of one "stend.fit/1" document as the run report's temperature plots
// use it — the typed model (estimation::read_fit_model; the evaluation, with its standard error,
// is estimation::InstrumentModel::contribution, through the vocabulary) and the document's interval
// quantile. The exports read typed results through the registry instead (export_sources.hpp).
#pragma once

#include "stend/estimation/result_io.hpp"

#include <nlohmann/json.hpp>

#include <utility>

namespace stend::reporting::detail {

struct FittedModel {
  estimation::InstrumentModel model;
  double quantile = 1.96;  // of the document's intervals (solution.quantile)
  bool ok = false;         // the document has a model of the vocabulary's terms
};

inline FittedModel fitted_model(const nlohmann::json& fit) {
  FittedModel f;
  if (auto m = estimation::read_fit_model(fit)) {
    f.ok = m->ok();
    f.model = std::move(*m);
  }
  const nlohmann::json solution = fit.value("solution", nlohmann::json::object());
  if (solution.contains("quantile") && solution["quantile"].is_number()) f.quantile = solution["quantile"].get<double>();
  return f;
}

// Output axis k of the model's contribution at (input u, temperature T) and its standard error.
inline std::pair<double, double> contribution(const FittedModel& f, int k, const model::Vec3<double>& u, double T,
                                              const model::Vec3<double>* minus_u = nullptr) {
  return f.model.contribution(k, u, T, minus_u);
}

}  // namespace stend::reporting::detail
