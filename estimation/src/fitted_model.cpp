// A linear error model read back from its results document (see stend/estimation/fitted_model.hpp).
#include "stend/estimation/fitted_model.hpp"

#include "stend/estimation/json_fields.hpp"

#include <algorithm>
#include <cmath>

namespace stend::estimation {

FittedModel fitted_model(const nlohmann::json& fit) {
  FittedModel f;
  const nlohmann::json mj = fit.value("model", nlohmann::json::object());
  f.m.instrument = text_field(mj, "instrument") == "gyroscope" ? model::Instrument::kGyroscope : model::Instrument::kAccelerometer;
  for (const auto& t : mj.value("terms", nlohmann::json::array())) {
    const auto k = model::term_from_name(text_field(t, "kind"));
    if (!k) return f;
    model::TermSpec s;
    s.kind = *k;
    if (t.contains("order")) s.order = t["order"].get<int>();
    if (t.contains("reference_c")) s.reference_c = t["reference_c"].get<double>();
    f.m.terms.push_back(s);
  }
  f.theta.assign(static_cast<std::size_t>(f.m.size()), 0.0);
  const nlohmann::json ps = fit.value("parameters", nlohmann::json::array());
  const auto n = ps.size();
  f.cov = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  const nlohmann::json corr = fit.value("correlation", nlohmann::json::array());
  for (std::size_t i = 0; i < n; ++i) {
    const int idx = ps[i].value("index", -1);
    f.index.push_back(idx);
    const double v = number_field(ps[i], "value");
    if (idx >= 0 && idx < f.m.size() && std::isfinite(v)) f.theta[static_cast<std::size_t>(idx)] = v;
    else f.not_identified.push_back(text_field(ps[i], "name"));
    for (std::size_t j = 0; j < n; ++j) {
      const double c = corr.is_array() && i < corr.size() ? number_at(corr[i], j) : (i == j ? 1.0 : 0.0);
      const double v2 = (std::isfinite(c) ? c : 0.0) * number_field(ps[i], "std_error") * number_field(ps[j], "std_error");
      f.cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = std::isfinite(v2) ? v2 : 0.0;
    }
  }
  const double q = number_field(fit.value("solution", nlohmann::json::object()), "quantile");
  if (std::isfinite(q)) f.quantile = q;
  f.ok = true;
  return f;
}

std::pair<double, double> contribution(const FittedModel& f, int k, const model::Vec3<double>& u, double T,
                                       const model::Vec3<double>* minus_u) {
  auto stim = [&](const model::Vec3<double>& in) {
    model::Stimulus<double> s;
    s.input = in;
    s.specific_force = f.m.instrument == model::Instrument::kAccelerometer ? in : model::Vec3<double>::Zero();
    s.temperature_c = T;
    return s;
  };
  const auto s = stim(u);
  double y = f.m.measure<double>(f.theta.data(), s)[k] - u[k];
  Eigen::RowVectorXd row = f.m.regressor(s).row(k);
  if (minus_u) {
    const auto s0 = stim(*minus_u);
    y -= f.m.measure<double>(f.theta.data(), s0)[k] - (*minus_u)[k];
    row -= f.m.regressor(s0).row(k);
  }
  Eigen::VectorXd gvec(static_cast<Eigen::Index>(f.index.size()));
  for (std::size_t i = 0; i < f.index.size(); ++i)
    gvec[static_cast<Eigen::Index>(i)] = f.index[i] >= 0 && f.index[i] < row.size() ? row[f.index[i]] : 0.0;
  const double var = gvec.dot(f.cov * gvec);
  return {y, std::sqrt(std::max(0.0, var))};
}

}  // namespace stend::estimation
