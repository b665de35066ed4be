// Values stated for undetermined parameters. See stend/estimation/assumption.hpp.
#include "stend/estimation/assumption.hpp"

#include "stend/errors.hpp"
#include "stend/estimation/model_spec.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stend::estimation {

namespace {

// A parameter the fit did not determine: its model and θ index.
struct Undetermined {
  InstrumentModel* model;
  std::size_t index;
  const ParameterEstimate& parameter() const { return model->parameters[index]; }
  model::Instrument instrument() const { return model->instrument(); }
};

// The instrument's prefix in an assumption's name ("accel_bias_x").
std::string prefix_of(model::Instrument i) { return i == model::Instrument::kAccelerometer ? "accel_" : "gyro_"; }

bool names(const std::string& name, const Undetermined& u) {
  return name == u.parameter().name || name == prefix_of(u.instrument()) + u.parameter().name;
}

std::string why(const ParameterEstimate& p) { return p.reason.empty() ? "not identifiable" : p.reason; }

// The parameters that need a value, one line each (a parameter of several models once), and the
// --assume that would give them all 0.
std::string refusal(const std::vector<Undetermined>& open, bool both_instruments, const std::string& action) {
  std::vector<std::string> seen;
  std::string lines, assume;
  for (const auto& u : open) {
    const std::string name = (both_instruments ? prefix_of(u.instrument()) : std::string()) + u.parameter().name;
    if (std::find(seen.begin(), seen.end(), name) != seen.end()) continue;
    seen.push_back(name);
    lines += fmt::format("\n  {} {} [{}]: {}", instrument_name(u.instrument()), u.parameter().name, u.parameter().unit,
                         why(u.parameter()));
    assume += (assume.empty() ? "" : ",") + name + "=0";
  }
  return fmt::format("cannot {}: the fit did not determine {} parameter(s), and writing them as 0 would be a "
                     "guess:{}\nfit on data that determine them, or state the values to use (each in its unit as "
                     "listed), e.g. --assume {}",
                     action, seen.size(), lines, assume);
}

}  // namespace

std::vector<Assumption> parse_assumptions(const std::string& text) {
  std::vector<Assumption> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t eq = item.find('=');
    Assumption a;
    bool ok = eq != std::string::npos && eq > 0;
    if (ok) {
      a.name = item.substr(0, eq);
      try {
        std::size_t used = 0;
        a.value = std::stod(item.substr(eq + 1), &used);
        ok = used == item.size() - eq - 1 && std::isfinite(a.value);
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok)
      throw std::invalid_argument("--assume '" + item +
                                  "': expected NAME=VALUE (comma-separated), the value a finite number in the "
                                  "parameter's unit as the results list it, e.g. bias_x=0 or gyro_bias_z=0.001");
    out.push_back(a);
    start = comma + 1;
  }
  return out;
}

std::vector<std::string> settle_undetermined(const std::vector<InstrumentModel*>& models,
                                             const std::vector<Assumption>& assumed, const std::string& source,
                                             const std::string& action) {
  std::vector<Undetermined> open;
  bool accel = false, gyro = false;
  for (InstrumentModel* m : models) {
    if (m == nullptr) continue;
    (m->instrument() == model::Instrument::kAccelerometer ? accel : gyro) = true;
    for (std::size_t i = 0; i < m->parameters.size() && i < m->theta.size(); ++i)
      if (!m->determined(i)) open.push_back({m, i});
  }
  const bool both = accel && gyro;
  const auto refuse = [&](const std::string& why) { throw InputError(source + ": " + why); };
  std::vector<bool> given(open.size(), false);
  std::vector<std::string> lines;
  for (const auto& a : assumed) {
    std::vector<std::size_t> hits;
    for (std::size_t k = 0; k < open.size(); ++k)
      if (names(a.name, open[k])) hits.push_back(k);
    if (hits.empty())
      refuse(fmt::format("--assume {}: not a parameter the fit left undetermined{}", a.name,
                         open.empty() ? " (this calibration has none)" : "; " + refusal(open, both, action)));
    for (std::size_t k : hits)
      if (open[k].instrument() != open[hits.front()].instrument())
        refuse(fmt::format("--assume {}: both instruments have it: write {}{} or {}{}", a.name,
                           prefix_of(model::Instrument::kAccelerometer), a.name,
                           prefix_of(model::Instrument::kGyroscope), a.name));
    for (std::size_t k : hits) {
      given[k] = true;
      open[k].model->theta[open[k].index] = a.value;
    }
    const Undetermined& u = open[hits.front()];
    lines.push_back(fmt::format("{} {} = {} {} ({})", instrument_name(u.instrument()), u.parameter().name,
                                number_text(a.value, 9), u.parameter().unit, why(u.parameter())));
  }
  std::vector<Undetermined> left;
  for (std::size_t k = 0; k < open.size(); ++k)
    if (!given[k]) left.push_back(open[k]);
  if (!left.empty()) refuse(refusal(left, both, action));
  return lines;
}

}  // namespace stend::estimation
