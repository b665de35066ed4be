// Bias and scale versus temperature on the batch least-squares estimator. See
// stend/temp_poly/temp_poly.hpp.
#include "stend/temp_poly/temp_poly.hpp"
#include "stend/sdk.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>

namespace stend::temp_poly {

namespace {


// Formats are literals at every call site (printf-style helper).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
std::string num(double v, const char* fmt = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}
#pragma GCC diagnostic pop

bool all_identifiable(const batch_lsq::FitResult& f) {
  if (!f.ok()) return false;
  for (const auto& p : f.lsq.parameters)
    if (!p.identifiable) return false;
  return true;
}

// Δ predicted for point `pt` on axis `a` by a fit (NaN when a needed parameter is not identified).
double predict(const batch_lsq::FitResult& f, const processing::StaticPoint& pt, int a) {
  const Eigen::MatrixXd phi = f.spec.model.regressor(pt.stimulus);
  double s = 0.0;
  for (std::size_t j = 0; j < f.param_index.size(); ++j) {
    const double c = phi(a, f.param_index[j]);
    if (c != 0.0) s += c * f.lsq.estimate[static_cast<Eigen::Index>(j)];
  }
  return s;
}

// Steps 2–3 (see the header): checks, temperature levels and legs, the orders the data support.

// Why the options or the points cannot be fitted at all; "" when they can.
std::string refusal(const TempPolyOptions& o, const std::vector<processing::StaticPoint>& points) {
  if (std::string why; !o.IsValid(&why)) return why;
  if (points.empty()) return "no static points: nothing to fit";
  for (const auto& p : points)
    if (!std::isfinite(p.stimulus.temperature_c))
      return "point '" + processing::label(p.segment) + "' has no finite temperature";
  return {};
}

// Point indices ordered by `key` (stable: equal keys keep their input order).
template <class Key>
std::vector<std::size_t> order_by(const std::vector<processing::StaticPoint>& points, Key key) {
  std::vector<std::size_t> idx(points.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  std::stable_sort(idx.begin(), idx.end(),
                   [&](std::size_t i, std::size_t j) { return key(points[i]) < key(points[j]); });
  return idx;
}

// Temperature levels: clusters of the ascending die temperatures, a gap above
// level_tolerance_c [degC] starting a new level; fills levels, level_of and the valid range [degC].
void group_levels(const std::vector<processing::StaticPoint>& points, double level_tolerance_c,
                  TempPolyResult& r) {
  r.level_of.assign(points.size(), -1);
  double prev = kNaN;
  for (std::size_t i : order_by(points, [](const auto& p) { return p.stimulus.temperature_c; })) {
    const double t = points[i].stimulus.temperature_c;
    if (r.levels.empty() || t - prev > level_tolerance_c) {
      r.levels.push_back({});
      r.levels.back().min_c = t;
    }
    TemperatureLevel& L = r.levels.back();
    L.temperature_c += t;
    L.max_c = t;
    ++L.points;
    r.level_of[i] = static_cast<int>(r.levels.size()) - 1;
    prev = t;
  }
  for (auto& L : r.levels) L.temperature_c /= L.points;
  r.valid_min_c = r.levels.front().min_c;
  r.valid_max_c = r.levels.back().max_c;
}

// Legs: visits (runs of one level) in time order; a visit approached from a colder level is
// heating, from a warmer one cooling, the first visit unknown. Fills legs and the level counts.
void assign_legs(const std::vector<processing::StaticPoint>& points, TempPolyResult& r) {
  r.legs.assign(points.size(), Leg::kUnknown);
  int prev_level = -1, cur_level = -1;
  Leg cur_leg = Leg::kUnknown;
  for (std::size_t i : order_by(points, [](const auto& p) { return p.t_start_s; })) {
    const int lv = r.level_of[i];
    if (lv != cur_level) {
      prev_level = cur_level;
      cur_level = lv;
      cur_leg = prev_level < 0 ? Leg::kUnknown : (lv > prev_level ? Leg::kHeating : Leg::kCooling);
    }
    r.legs[i] = cur_leg;
    TemperatureLevel& L = r.levels[static_cast<std::size_t>(lv)];
    (cur_leg == Leg::kHeating ? L.heating_points
                              : cur_leg == Leg::kCooling ? L.cooling_points : L.unknown_points)++;
  }
}

// "N distinct temperature level(s) (…)": what the data offer, for refusals and notes.
std::string levels_text(const TempPolyResult& r, double level_tolerance_c) {
  std::string level_list;
  for (const auto& L : r.levels) level_list += (level_list.empty() ? "" : ", ") + num(L.temperature_c, "%.1f");
  return std::to_string(r.levels.size()) + " distinct temperature level(s) (" + level_list +
         " degC, levels closer than level_tolerance_c = " + num(level_tolerance_c) + " degC merged)";
}

// The highest candidate order the span [degC] and the number of levels support; -1 with
// r.message set when they support none of the requested orders.
int highest_order(const TempPolyOptions& o, TempPolyResult& r) {
  const double span = r.valid_max_c - r.valid_min_c;
  const int nlevels = static_cast<int>(r.levels.size());
  const int requested = o.selection == "fixed" ? o.order : o.max_order;
  if (requested >= 1 && span < o.min_span_c) {
    r.message = "temperature span " + num(span, "%.3g") + " degC (" + num(r.valid_min_c, "%.2f") +
                " to " + num(r.valid_max_c, "%.2f") + " degC) is below min_span_c = " +
                num(o.min_span_c) + " degC: temperature coefficients would be extrapolation-grade. "
                "Extend the sweep or lower min_span_c.";
    return -1;
  }
  if (o.selection == "fixed") {
    if (nlevels >= o.order + 1) return o.order;
    r.message = "order " + std::to_string(o.order) + " needs at least " +
                std::to_string(o.order + 1) + " distinct temperature levels; the data have " +
                levels_text(r, o.level_tolerance_c) + ". Add temperature steps or lower the order.";
    return -1;
  }
  const int need_extra = o.selection == "cv" ? 2 : 1;  // cv: every fold keeps order+1 levels
  const int top = std::min(o.max_order, nlevels - need_extra);
  if (top < 1) {
    r.message = std::string("selection '") + o.selection + "' needs at least " +
                std::to_string(1 + need_extra) + " distinct temperature levels for order 1; the " +
                "data have " + levels_text(r, o.level_tolerance_c) + ". Add temperature steps.";
    return -1;
  }
  if (top < o.max_order)
    r.notes.push_back("orders " + std::to_string(top + 1) + ".." + std::to_string(o.max_order) +
                      " not tried: the data have " + levels_text(r, o.level_tolerance_c));
  return top;
}

// Notes on the data: T0 outside the measured range [degC], and how many points each leg holds.
void add_range_notes(const TempPolyOptions& o, TempPolyResult& r) {
  if (o.reference_c < r.valid_min_c || o.reference_c > r.valid_max_c)
    r.notes.push_back("reference_c = " + num(o.reference_c) + " degC lies outside the measured range " +
                      num(r.valid_min_c, "%.2f") + "…" + num(r.valid_max_c, "%.2f") +
                      " degC: bias and scale at T0 are extrapolated");
  int heating = 0, cooling = 0;
  for (Leg l : r.legs) {
    heating += l == Leg::kHeating;
    cooling += l == Leg::kCooling;
  }
  r.notes.push_back("legs used: " + std::to_string(heating) + " heating, " + std::to_string(cooling) +
                    " cooling, " + std::to_string(static_cast<int>(r.legs.size()) - heating - cooling) +
                    " unknown-direction point(s) (first visit)");
}

// Steps 4–5, per axis: candidate orders, scores, choice, hysteresis.

// A candidate's score: BIC = n·ln(RSS/n) + rank·ln(n), valid when every parameter is identified.
OrderScore score_fit(const batch_lsq::FitResult& f, int order) {
  OrderScore s;
  s.order = order;
  s.observations = f.lsq.observations;
  if (!f.ok()) {
    s.note = "fit failed: " + f.message;
    return s;
  }
  s.parameters = f.lsq.rank;
  s.rss = f.lsq.rss;
  const double nn = f.lsq.observations;
  s.bic = nn * std::log(std::max(f.lsq.rss, 1e-300) / nn) + f.lsq.rank * std::log(nn);
  s.ok = all_identifiable(f);
  if (!s.ok) s.note = "not every parameter is identifiable at this order";
  return s;
}

// Leave-one-temperature-out cross-validation of `spec` on axis a: the mean squared error
// [unit²] of each level's points predicted by a fit without that level, into s.cv_mse.
void cross_validate(const std::vector<processing::StaticPoint>& points, const TempPolyResult& r,
                    const estimation::ModelSpec& spec, int a, OrderScore& s) {
  double sse = 0.0;
  int count = 0;
  std::string why;
  for (std::size_t lv = 0; lv < r.levels.size(); ++lv) {
    std::vector<processing::StaticPoint> train;
    std::vector<std::size_t> test;
    for (std::size_t i = 0; i < points.size(); ++i)
      (r.level_of[i] == static_cast<int>(lv) ? (void)test.push_back(i) : train.push_back(points[i]));
    const batch_lsq::FitResult tf = batch_lsq::fit_points(train, spec);
    if (!all_identifiable(tf)) {
      why = "without level " + num(r.levels[lv].temperature_c, "%.1f") + " degC the fit is " +
            (tf.ok() ? "not identifiable" : "refused: " + tf.message);
      break;
    }
    for (std::size_t i : test) {
      const double e = points[i].axes(spec.model.instrument).mean[a] - points[i].stimulus.input[a] -
                       predict(tf, points[i], a);
      sse += e * e;
      ++count;
    }
  }
  if (why.empty() && count > 0) {
    s.cv_ok = true;
    s.cv_mse = sse / count;
  } else {
    s.note += (s.note.empty() ? "" : "; ") + std::string("cv: ") + why;
  }
}

// Index of the candidate `selection` picks: the last (fixed), the lowest BIC or the lowest CV
// error among the scored ones; -1 when none is scored.
int choose_candidate(const std::vector<OrderScore>& scores, const std::string& selection) {
  int best = -1;
  for (std::size_t k = 0; k < scores.size(); ++k) {
    const OrderScore& s = scores[k];
    const OrderScore* b = best < 0 ? nullptr : &scores[static_cast<std::size_t>(best)];
    if (selection == "fixed" || (selection == "bic" && s.ok && (!b || s.bic < b->bic)) ||
        (selection == "cv" && s.cv_ok && (!b || s.cv_mse < b->cv_mse)))
      best = static_cast<int>(k);
  }
  return best;
}

// Hysteresis at level lv of axis a: cooling minus heating mean residual of the chosen fit
// [unit], with its standard error and interval at the fit's confidence.
Hysteresis level_hysteresis(const TempPolyResult& r, const AxisResult& ax, int lv) {
  const TemperatureLevel& L = r.levels[static_cast<std::size_t>(lv)];
  Hysteresis h;
  h.level = lv;
  h.temperature_c = L.temperature_c;
  double sh = 0.0, sc = 0.0;
  for (const auto& res : ax.fit.residuals) {
    const auto i = static_cast<std::size_t>(res.point);
    if (res.axis != ax.axis || r.level_of[i] != lv) continue;
    if (r.legs[i] == Leg::kHeating) {
      sh += res.residual;
      ++h.heating_points;
    } else if (r.legs[i] == Leg::kCooling) {
      sc += res.residual;
      ++h.cooling_points;
    }
  }
  if (h.heating_points > 0 && h.cooling_points > 0) {
    const double sigma = std::sqrt(ax.fit.lsq.sigma2);
    h.value = sc / h.cooling_points - sh / h.heating_points;
    h.std_error = sigma * std::sqrt(1.0 / h.cooling_points + 1.0 / h.heating_points);
    h.lower = h.value - ax.fit.lsq.quantile * h.std_error;
    h.upper = h.value + ax.fit.lsq.quantile * h.std_error;
    h.significant = h.lower > 0.0 || h.upper < 0.0;
  }
  return h;
}

// Hysteresis at every level visited on both legs, and the largest |value| [unit].
void add_hysteresis(const TempPolyResult& r, AxisResult& ax) {
  for (std::size_t lv = 0; lv < r.levels.size(); ++lv) {
    const TemperatureLevel& L = r.levels[lv];
    if (L.heating_points == 0 || L.cooling_points == 0) continue;
    const Hysteresis h = level_hysteresis(r, ax, static_cast<int>(lv));
    if (h.heating_points > 0 && h.cooling_points > 0 &&
        !(std::abs(h.value) <= std::abs(ax.max_abs_hysteresis)))
      ax.max_abs_hysteresis = std::abs(h.value);
    ax.hysteresis.push_back(h);
  }
}

// One axis: candidate orders first..top fitted and scored, one chosen, its hysteresis.
AxisResult fit_axis(const std::vector<processing::StaticPoint>& points, const TempPolyOptions& o,
                    const TempPolyResult& r, int first, int top, int a) {
  AxisResult ax;
  ax.axis = a;
  std::vector<batch_lsq::FitResult> fits;
  for (int m = first; m <= top; ++m) {
    const estimation::ModelSpec spec = candidate_spec(o, m, a);
    fits.push_back(batch_lsq::fit_points(points, spec));
    OrderScore s = score_fit(fits.back(), m);
    if (s.ok && o.selection != "fixed") cross_validate(points, r, spec, a, s);
    ax.scores.push_back(s);
  }
  const int best = choose_candidate(ax.scores, o.selection);
  if (best < 0) {
    ax.message = std::string("no candidate order could be scored by ") + o.selection + " on axis " +
                 estimation::axis_name(a) + " (see the order table)";
    return ax;
  }
  ax.fit = fits[static_cast<std::size_t>(best)];
  ax.chosen_order = ax.scores[static_cast<std::size_t>(best)].order;
  ax.status = ax.fit.status;
  if (!ax.fit.ok()) ax.message = "axis " + std::string(1, estimation::axis_name(a)) + ": " + ax.fit.message;
  if (ax.ok()) add_hysteresis(r, ax);
  return ax;
}

}  // namespace

const char* leg_name(Leg leg) {
  switch (leg) {
    case Leg::kHeating: return "heating";
    case Leg::kCooling: return "cooling";
    case Leg::kUnknown: break;
  }
  return "unknown";
}

const AxisResult& TempPolyResult::axis(int a) const {
  for (const auto& r : axes)
    if (r.axis == a) return r;
  throw std::out_of_range(std::string("temp_poly: axis ") + estimation::axis_name(a) +
                          " was not fitted");
}

estimation::ModelSpec candidate_spec(const TempPolyOptions& o, int order, int axis) {
  estimation::ModelSpec spec;
  spec.model.instrument = o.instrument;
  spec.model.terms.push_back({model::TermKind::kBias, 1, o.reference_c});
  if (o.scale) spec.model.terms.push_back({model::TermKind::kScale, 1, o.reference_c});
  if (o.cross_axis) spec.model.terms.push_back({model::TermKind::kCrossAxis, 1, o.reference_c});
  if (order > 0) {
    if (o.bias_temperature)
      spec.model.terms.push_back({model::TermKind::kBiasTemperature, order, o.reference_c});
    if (o.scale_temperature)
      spec.model.terms.push_back({model::TermKind::kScaleTemperature, order, o.reference_c});
  }
  spec.axes = axis >= 0 ? std::vector<int>{axis} : o.axes;
  spec.processing = o.processing;
  spec.weighting = estimation::Weighting::kNone;
  spec.confidence = o.confidence;
  spec.tolerances = o.tolerances;
  spec.source = "temp_poly";
  return spec;
}

TempPolyResult fit_temperature_points(const std::vector<processing::StaticPoint>& points,
                                      const TempPolyOptions& o) {
  TempPolyResult r;
  r.options = o;
  r.points = points;
  r.reference_c = o.reference_c;
  r.unit = o.instrument == model::Instrument::kAccelerometer ? "m/s^2" : "rad/s";
  r.message = refusal(o, points);
  if (!r.message.empty()) return r;
  group_levels(points, o.level_tolerance_c, r);
  assign_legs(points, r);
  const int top = highest_order(o, r);
  if (top < 0) return r;
  add_range_notes(o, r);
  const int first = o.selection == "fixed" ? o.order : 0;
  bool all_ok = true;
  for (int a : o.axes) {
    AxisResult ax = fit_axis(points, o, r, first, top, a);
    all_ok = all_ok && ax.ok();
    if (!ax.ok() && r.message.empty()) r.message = ax.message;
    r.axes.push_back(std::move(ax));
  }
  r.status = all_ok ? estimation::FitStatus::kOk : estimation::FitStatus::kFailed;
  return r;
}

TempPolyResult fit_temperature_model(const Recording& rec, const TempPolyOptions& o) {
  processing::Extraction ex;
  TempPolyResult r;
  try {
    ex = estimation::extract_static_points(rec, candidate_spec(o, 0, -1));
  } catch (const std::exception& e) {
    r.options = o;
    r.reference_c = o.reference_c;
    r.message = e.what();
    r.recording_dir = rec.dir.string();
    r.experiment_name = rec.header.experiment_name;
    return r;
  }
  TempPolyOptions used = o;
  used.processing = ex.options;
  r = fit_temperature_points(ex.points, used);
  if (!r.ok() && ex.points.empty()) r.message = "no usable static segment in the recording; " + r.message;
  r.notes.insert(r.notes.begin(), ex.notes.begin(), ex.notes.end());
  if (!rec.complete())
    r.notes.push_back("the recording's status is '" + std::string(to_string(rec.header.status)) + "', not 'complete'");
  r.recording_dir = rec.dir.string();
  r.experiment_name = rec.header.experiment_name;
  return r;
}

}  // namespace stend::temp_poly
