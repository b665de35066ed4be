// The noise types' text: a point, the curve table, coefficients, read-offs, the model. See
// stend/noise/noise_model.hpp.
#include <fmt/format.h>

#include <cmath>
#include <ostream>
#include <string>

#include "stend/noise/noise_model.hpp"

namespace stend::noise {

std::ostream& operator<<(std::ostream& os, const AllanPoint& p) {
  os << fmt::format("tau {:.6g} s (m {}): adev {:.5g} [{:.5g}, {:.5g}], edf {:.4g} ({})", p.tau_s,
                    p.m, p.adev, p.adev_lo, p.adev_hi, p.edf, to_string(p.noise));
  return os;
}

std::ostream& operator<<(std::ostream& os, const AllanCurve& c) {
  os << fmt::format("Allan deviation of {} ({}, {}), {} samples at {:.6g} Hz, {:.1f} % intervals\n",
                    c.channel.name, to_string(c.channel.instrument), c.units.signal, c.samples,
                    c.rate_hz, 100.0 * c.confidence);
  os << fmt::format("  {:>12} {:>10} {:>12} {:>12} {:>12} {:>10}  {}\n", "tau [s]", "m", "adev",
                    "lo", "hi", "edf", "noise (EDF)");
  for (const auto& p : c.points) {
    os << fmt::format("  {:>12.6g} {:>10} {:>12.5g} {:>12.5g} {:>12.5g} {:>10.4g}  {}\n", p.tau_s,
                      p.m, p.adev, p.adev_lo, p.adev_hi, p.edf, to_string(p.noise));
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const Coefficient& c) {
  switch (c.verdict()) {
    case Verdict::kFailed: return os << fmt::format("{} ({}): FIT FAILED", c.symbol, c.name);
    case Verdict::kIdentified:
      os << fmt::format("{} ({}) = {:.4g} ± {:.2g} {} (95 % {:.4g} … {:.4g})", c.symbol, c.name, c.value,
                        c.sigma, c.unit, c.lo, c.hi);
      if (c.dominates) os << fmt::format("  [dominates {:.3g} … {:.3g} s]", c.tau_lo_s, c.tau_hi_s);
      return os;
    case Verdict::kUpperBound:
      if (!std::isfinite(c.upper_bound)) return os << fmt::format("{} ({}): not identified", c.symbol, c.name);
      return os << fmt::format("{} ({}): not identified; <= {:.3g} {}", c.symbol, c.name, c.upper_bound, c.unit);
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const Readoff& r) {
  if (r.found) {
    os << fmt::format("{} = {:.4g} {} [{:.4g}, {:.4g}] from tau {:.3g} … {:.3g} s", r.name, r.value,
                      r.unit, r.lo, r.hi, r.tau_lo_s, r.tau_hi_s);
  } else {
    os << fmt::format("{}: not found — {}", r.name, r.note);
  }
  return os;
}

std::ostream& operator<<(std::ostream& os, const NoiseModel& m) {
  if (!m.ok) return os << "noise model: FIT FAILED — " << m.message << "\n";
  os << fmt::format("noise model fitted over tau {:.3g} … {:.3g} s (deviance per dof {:.3g}, {} dof), "
                    "output low-pass {}:\n",
                    m.tau_fit_min_s, m.tau_fit_max_s, m.chi2_reduced, m.dof,
                    std::isnan(m.lowpass_hz) ? std::string("not stated")
                    : m.lowpass_hz > 0.0     ? fmt::format("{:g} Hz in the model", m.lowpass_hz)
                                             : std::string("none"));
  os << "  selected terms: " << m.selection << "\n";
  for (int j = 0; j < NoiseModel::kCoefficients; ++j) {
    const Coefficient& c = m.coefficients()[j];
    if (std::string(c.symbol) == "Tc" && !c.identified) continue;  // τc only with its σ_G
    os << "  " << c << "\n";
  }
  os << "  read-offs: " << m.white_line << "\n";
  os << "             " << m.random_walk_line << "\n";
  os << "             " << m.bias_floor << "\n";
  if (!m.message.empty()) os << "  note: " << m.message << "\n";
  return os;
}

std::ostream& operator<<(std::ostream& os, const ChannelResult& r) {
  return os << r.curve << r.model;
}

}  // namespace stend::noise
