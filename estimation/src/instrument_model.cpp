// One instrument's fitted error model (see stend/estimation/instrument_model.hpp).
#include "stend/estimation/instrument_model.hpp"

#include "stend/estimation/model_spec.hpp"
#include "stend/recording/instruments.hpp"
#include "stend/sdk.hpp"  // kNaN

#include <algorithm>
#include <ostream>

namespace stend::estimation {

bool InstrumentModel::covers(int axis) const { return std::find(axes.begin(), axes.end(), axis) != axes.end(); }

const ParameterEstimate* InstrumentModel::find(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return &p;
  return nullptr;
}

double InstrumentModel::std_error(const std::string& name) const {
  const ParameterEstimate* p = find(name);
  return p != nullptr && std::isfinite(p->std_error) ? p->std_error : 0.0;
}

bool InstrumentModel::determined(std::size_t i) const {
  if (i >= parameters.size() || i >= theta.size()) return false;
  return parameters[i].held ? parameters[i].zero_is_exact : std::isfinite(theta[i]);
}

std::vector<std::string> InstrumentModel::not_identified() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < theta.size() && i < parameters.size(); ++i)
    if (!determined(i)) out.push_back(parameters[i].name);
  return out;
}

std::vector<double> InstrumentModel::applied_theta() const {
  std::vector<double> t = theta;
  for (double& v : t)
    if (!std::isfinite(v)) v = 0.0;
  return t;
}

std::pair<double, double> InstrumentModel::contribution(int k, const model::Vec3<double>& u, double temperature_c,
                                                        const model::Vec3<double>* minus_u) const {
  const std::vector<double> th = applied_theta();
  auto stimulus = [&](const model::Vec3<double>& in) {
    model::Stimulus<double> s;
    s.input = in;
    s.specific_force = model.instrument == model::Instrument::kAccelerometer ? in : model::Vec3<double>::Zero();
    s.temperature_c = temperature_c;
    return s;
  };
  const model::Stimulus<double> s = stimulus(u);
  double y = model.measure<double>(th.data(), s)[k] - u[k];
  Eigen::RowVectorXd row = model.regressor(s).row(k);
  if (minus_u != nullptr) {
    const model::Stimulus<double> s0 = stimulus(*minus_u);
    y -= model.measure<double>(th.data(), s0)[k] - (*minus_u)[k];
    row -= model.regressor(s0).row(k);
  }
  if (covariance.rows() != row.size() || covariance.cols() != row.size()) return {y, kNaN};
  const double var = row.dot(covariance * row.transpose());
  return {y, std::sqrt(std::max(0.0, var))};
}

void InstrumentModel::print(std::ostream& os) const {
  model.print(os);
  os << " (axes";
  for (int a : axes) os << " " << axis_name(a);
  os << (coverage == Coverage::kTriad ? " as one triad" : " each on its own") << "; " << status_text(status)
     << (message.empty() ? "" : ": " + message) << ")\n";
  for (const auto& f : failed_axes) os << "axis " << axis_name(f.axis) << " failed: " << f.message << "\n";
  if (!ok()) return;
  print_parameter_header(os, confidence);
  for (const auto& p : parameters) os << p << "\n";
  for (const auto& n : notes) os << "note: " << n << "\n";
}

std::string why_absent(const SensorInfo& info, model::Instrument instrument) {
  return has_instrument(info, instrument) ? std::string() : absent_text(instrument);
}

std::string why_no_temperature(const SensorInfo& info, const std::vector<std::string>& temperature_terms) {
  if (info.has_temperature || temperature_terms.empty()) return {};
  std::string names;
  for (const auto& t : temperature_terms) names += (names.empty() ? "" : ", ") + t;
  return "the recording has no temperature (its source holds none), which the model's temperature term(s) " + names +
         " need; remove them to fit the rest";
}

InstrumentModel not_applicable(model::ErrorModel model, const std::string& why) {
  InstrumentModel m;
  m.status = FitStatus::kNotApplicable;
  m.message = why;
  m.model = std::move(model);
  return m;
}

std::ostream& operator<<(std::ostream& os, const InstrumentModel& m) {
  m.print(os);
  return os;
}

bool InstrumentModel::equals(const InstrumentModel& o, double rel_tol, double abs_tol) const {
  if (status != o.status || message != o.message || !model.equals(o.model) || coverage != o.coverage ||
      axes != o.axes || theta.size() != o.theta.size() || parameters.size() != o.parameters.size() ||
      failed_axes.size() != o.failed_axes.size() || notes != o.notes)
    return false;
  const double mine[] = {confidence, reference_c, min_temperature_c, max_temperature_c, gravity_mps2};
  const double theirs[] = {o.confidence, o.reference_c, o.min_temperature_c, o.max_temperature_c, o.gravity_mps2};
  for (int i = 0; i < 5; ++i)
    if (!nearly_equal(mine[i], theirs[i], rel_tol, abs_tol)) return false;
  for (std::size_t i = 0; i < theta.size(); ++i)
    if (!nearly_equal(theta[i], o.theta[i], rel_tol, abs_tol) || !parameters[i].equals(o.parameters[i], rel_tol, abs_tol))
      return false;
  for (std::size_t i = 0; i < failed_axes.size(); ++i)
    if (failed_axes[i].axis != o.failed_axes[i].axis || failed_axes[i].message != o.failed_axes[i].message) return false;
  if (covariance.rows() != o.covariance.rows() || covariance.cols() != o.covariance.cols()) return false;
  for (Eigen::Index i = 0; i < covariance.size(); ++i)
    if (!nearly_equal(covariance.data()[i], o.covariance.data()[i], rel_tol, abs_tol)) return false;
  return true;
}

}  // namespace stend::estimation
