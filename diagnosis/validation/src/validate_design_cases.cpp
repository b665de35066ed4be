// `stend gap validate`: the design cases — folds that fit the design, aliases resolved by what the
// experiment excites, placement of hand-placed faces. See validate.hpp (DesignCase).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "stend/diagnosis/validate.hpp"
#include "stend/model/noise.hpp"
#include "stend/physics/units.hpp"

namespace stend::diagnosis {

namespace {

using Eigen::VectorXd;
using model::TermKind;
using model::TermSpec;

// The six axis-up/down table positions (tilt, rotation) [deg] of the default design.
const std::vector<std::pair<double, double>> kFaces = {{0, 0}, {0, 180}, {0, -90}, {0, 90}, {90, 0}, {-90, 0}};

estimation::ModelSpec model_of(std::vector<TermSpec> terms, const char* source) {
  estimation::ModelSpec s = validation_model();
  s.model.terms = std::move(terms);
  s.source = source;
  return s;
}

const TermSpec kBias{TermKind::kBias, 1, 25.0}, kScale{TermKind::kScale, 1, 25.0};

// The true model: the fitted model's terms at MEMS values (bias 0.05 m/s², scale 0.2 %) plus
// `extra` with parameters `theta`.
Planted truth_of(const estimation::ModelSpec& fit, model::Rng& rng, const std::vector<TermSpec>& extra = {},
                 const VectorXd& theta = {}) {
  Planted p;
  p.model = fit.model;
  for (const auto& t : extra) p.model.terms.push_back(t);
  p.theta = VectorXd::Zero(p.model.size());
  for (std::size_t k = 0; k < fit.model.terms.size(); ++k) {
    const int off = p.model.offset(k), n = model::param_count(p.model.terms[k]);
    const double sd = p.model.terms[k].kind == TermKind::kBias ? 0.05 : 0.002;
    for (int i = 0; i < n; ++i) p.theta[off + i] = sd * rng.normal();
  }
  if (theta.size() > 0) p.theta.tail(theta.size()) = theta;
  return p;
}

VectorXd normal_vector(model::Rng& rng, Eigen::Index n, double sd) {
  VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = sd * rng.normal();
  return v;
}

std::string first_named(const GapReport& r) { return r.ok ? (r.selected.empty() ? "(none)" : r.selected.front()) : "(failed)"; }

// The same term kind: "scale_temperature(order 2)" is scale_temperature, "scale" is not (a prefix
// test would take scale_temperature for scale).
bool same_kind(const std::string& named, const std::string& planted) {
  return named.substr(0, named.find('(')) == planted.substr(0, planted.find('('));
}

// One case: `runs` seeds of make → diagnose → pass.
template <class Make, class Pass>
DesignCase run_case(std::string name, std::string expected, bool null_case, int runs, std::uint64_t& seed,
                    const GapOptions& gap, Make make, Pass pass) {
  DesignCase c{std::move(name), std::move(expected), null_case, 0, 0, {}};
  for (int i = 0; i < runs; ++i) {
    const GapReport r = diagnose(make(seed++), gap);
    ++c.runs;
    ++c.named[first_named(r)];
    c.passed += pass(r) ? 1 : 0;
  }
  return c;
}

// The static tumble at one warm temperature: the die settles from 22 °C towards 40 and 43 °C.
ValidationDesign warm_design() {
  ValidationDesign d = default_design();
  d.setpoints_c = {40.0, 43.0};
  return d;
}

}  // namespace

GapInput generate_hand_faces(int repeats, double tilt_deg, const estimation::ModelSpec& fit_model, const Planted& truth,
                             std::uint64_t seed) {
  ValidationDesign d = default_design();
  d.setpoints_c = {25.0};
  d.positions.clear();
  model::Rng rng(seed ^ 0x5eed);
  for (int r = 0; r < repeats; ++r)
    for (const auto& [h, dl] : kFaces) d.positions.push_back({h + tilt_deg * rng.normal(), dl + tilt_deg * rng.normal()});
  GapInput in = generate(d, fit_model, truth, seed);
  for (std::size_t s = 0; s < in.segments.size(); ++s) {
    in.segments[s].orientation = static_cast<int>(s % kFaces.size());
    in.segments[s].orientation_name = "face " + std::to_string(s % kFaces.size() + 1);
    // Placed by hand: no table whose angles could be off.
    for (auto& v : in.segments[s].point.stimulus.table_df_dangle) v.setZero();
    for (auto& v : in.segments[s].point.stimulus.table_df_dtilt) v.setZero();
  }
  return in;
}

std::vector<DesignCase> run_design_cases(int runs, std::uint64_t seed, const GapOptions& gap) {
  std::vector<DesignCase> out;
  if (runs <= 0) return out;
  model::Rng rng(seed * 104729 + 3);
  std::uint64_t s = seed * 7777 + 1;
  const double g = physics::kStandardGravity;
  // Fold: hand-held faces, magnitude form, bias + scale, nothing planted.
  {
    const estimation::ModelSpec bs = model_of({kBias, kScale}, "bias + scale");
    out.push_back(run_case(
        "fold: hand-held six faces x5, magnitude form, bias+scale, null",
        "re-folded away from orientation folds, with the reason; nothing named or significant", true, runs, s, gap,
        [&](std::uint64_t sd) { return magnitude_form(generate_hand_faces(5, 3.0, bs, truth_of(bs, rng), sd), g); },
        [](const GapReport& r) {
          return r.ok && r.fold_by != FoldBy::kOrientation && !r.fold_reason.empty() && !claims_an_effect(r);
        }));
  }
  // Alias: warm static tumble, bias only; scale, scale_temperature(order 1), gravity_error planted.
  {
    const estimation::ModelSpec b = model_of({kBias}, "bias");
    const ValidationDesign d = warm_design();
    const auto scale_or_alias = [](const std::string& planted) {
      return [planted](const GapReport& r) {
        if (!r.ok || r.selected.empty()) return false;
        const std::string& n = r.selected.front();
        // A polynomial planted at one order must be named at that order (not at a higher one
        // that nests it); any other term by its kind.
        if (planted.find('(') != std::string::npos ? n == planted : same_kind(n, planted)) return true;
        if (n != "scale") return false;
        // scale named: the planted term must be listed as its alias.
        for (const auto& c : r.candidates)
          if (c.term == n)
            for (const auto& a : c.aliases)
              if (same_kind(a, planted)) return true;
        return false;
      };
    };
    out.push_back(run_case(
        "alias: warm tumble, bias only, planted scale (0.3 %)", "scale named first", false, runs, s, gap,
        [&](std::uint64_t sd) { return generate(d, b, truth_of(b, rng, {kScale}, normal_vector(rng, 3, 0.003)), sd); },
        scale_or_alias("scale")));
    out.push_back(run_case(
        "alias: warm tumble, bias only, planted scale_temperature(order 1)",
        "scale_temperature(order 1) named (not order 2), or scale with scale_temperature listed as its alias", false, runs, s, gap,
        [&](std::uint64_t sd) {
          return generate(d, b, truth_of(b, rng, {TermSpec{TermKind::kScaleTemperature, 1, 25.0}}, normal_vector(rng, 3, 2e-4)),
                          sd);
        },
        scale_or_alias("scale_temperature(order 1)")));
    out.push_back(run_case(
        "alias: warm tumble, bias only, planted gravity_error (0.3 %)",
        "scale named with gravity_error listed as its alias (no gravity reference)", false, runs, s, gap,
        [&](std::uint64_t sd) {
          return generate(d, b, truth_of(b, rng, {TermSpec{TermKind::kGravityError, 1, 25.0}}, normal_vector(rng, 1, 0.003 * g)),
                          sd);
        },
        scale_or_alias("gravity_error")));
  }
  // Placement: six faces placed twice, each face off by a planted rotation; bias + scale.
  {
    const estimation::ModelSpec bs = model_of({kBias, kScale}, "bias + scale");
    const auto placed = [&](std::uint64_t sd, double rms_deg) {
      Planted t = truth_of(bs, rng);
      std::vector<Eigen::Vector3d> rot;
      for (std::size_t k = 0; k < kFaces.size(); ++k)
        rot.push_back(Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()) * rms_deg * physics::kDegToRad / std::sqrt(2.0));
      GapInput probe = generate_hand_faces(2, 0.0, bs, t, sd);
      t.extra.assign(probe.segments.size(), Eigen::Vector3d::Zero());
      for (std::size_t i = 0; i < probe.segments.size(); ++i) {
        const Eigen::Vector3d& f = probe.segments[i].point.stimulus.specific_force;
        t.extra[i] = rot[i % kFaces.size()].cross(f);  // δf = δθ × f, the same placement both times
      }
      return generate_hand_faces(2, 0.0, bs, t, sd);
    };
    out.push_back(run_case("placement: six faces x2, each off by 1 deg RMS, bias+scale",
                           "placement family significant; any sensor term named lies within the per-face rotations "
                           "and is said to",
                           false, runs, s, gap, [&](std::uint64_t sd) { return placed(sd, 1.0); },
                           [](const GapReport& r) {
                             if (!r.ok || !r.placement.significant) return false;
                             for (const auto& n : r.selected)
                               if (std::find(r.placement.aliases.begin(), r.placement.aliases.end(), n) ==
                                   r.placement.aliases.end())
                                 return false;
                             return true;
                           }));
    out.push_back(run_case("placement: six faces x2, placed exactly, bias+scale, null",
                           "placement not significant, nothing named or significant", true, runs, s, gap,
                           [&](std::uint64_t sd) { return placed(sd, 0.0); },
                           [](const GapReport& r) { return r.ok && !claims_an_effect(r); }));
  }
  return out;
}

}  // namespace stend::diagnosis
