// A linear error model as its results document states it (schema stend.fit/1: batch_lsq's
// fit.json, each axis of temp_poly's results — the model's terms, each parameter's value by its
// index into θ, the covariance from the standard errors and correlations), evaluated only through
// the vocabulary (model::ErrorModel::measure / regressor): no term formula is written here. The
// reports draw temperature curves with it, the exports evaluate coefficients with it.
#pragma once

#include <stend/model/terms.hpp>

#include <nlohmann/json_fwd.hpp>

#include <Eigen/Dense>

#include <string>
#include <utility>
#include <vector>

namespace stend::estimation {

struct FittedModel {
  model::ErrorModel m;
  std::vector<double> theta;
  std::vector<int> index;       // per listed parameter: index into theta
  Eigen::MatrixXd cov;          // over listed parameters (identifiable ones; 0 elsewhere)
  double quantile = 1.96;       // of the fit's intervals
  bool ok = false;              // false: a term the vocabulary does not know
  std::vector<std::string> not_identified;  // parameter names left at 0 in theta
};

// The model of a stend.fit/1-shaped document ("model", "parameters", "correlation", "solution").
FittedModel fitted_model(const nlohmann::json& fit);

// Output axis `k` of the model's contribution at (input u, temperature T [°C]), i.e. measured − u,
// and its standard error from the parameter covariance (gradient = the regressor row); with
// `minus_u`, the difference to the contribution at that input.
std::pair<double, double> contribution(const FittedModel& f, int k, const model::Vec3<double>& u, double T,
                                       const model::Vec3<double>* minus_u = nullptr);

}  // namespace stend::estimation
