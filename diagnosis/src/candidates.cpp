// The candidates: every vocabulary term a model lacks, and the experiment that separates two
// terms a design cannot tell apart. See stend/diagnosis/gap.hpp.
#include <algorithm>
#include <initializer_list>

#include "linear_problem.hpp"

namespace stend::diagnosis {

using model::TermKind;
using model::TermSpec;

std::vector<Candidate> default_candidates(const model::ErrorModel& m, bool temperature_spread) {
  std::vector<Candidate> out;
  const bool gyro = m.instrument == model::Instrument::kGyroscope;
  std::vector<TermKind> kinds(model::kAllTermKinds.begin(), model::kAllTermKinds.end());
  kinds.insert(kinds.end(), model::kGapTermKinds.begin(), model::kGapTermKinds.end());
  for (TermKind k : kinds) {
    if (k == TermKind::kBias) continue;  // every model has it (a model without bias is checked too)
    if (k == TermKind::kGSensitivity && !gyro) continue;
    if (model::reads_temperature(k) && !temperature_spread) continue;  // assessed only with a temperature spread
    if ((k == TermKind::kGravityError || k == TermKind::kTableAngleOffset || k == TermKind::kTableAxisTilt ||
         k == TermKind::kLeverArm) && gyro)
      continue;
    const int have = m.find(k);
    if (k == TermKind::kBiasTemperature || k == TermKind::kScaleTemperature) {
      const int modelled = have >= 0 ? m.terms[static_cast<std::size_t>(have)].order : 0;
      for (int order = modelled + 1; order <= std::min(3, modelled + 2); ++order) {
        TermSpec t{k, order, 25.0};
        out.push_back({term_label(t), t});
      }
      continue;
    }
    if (have >= 0) continue;
    TermSpec t{k, 1, 25.0};
    out.push_back({term_label(t), t});
  }
  if (m.find(TermKind::kBias) < 0) out.insert(out.begin(), {"bias", TermSpec{TermKind::kBias, 1, 25.0}});
  return out;
}

std::string separating_experiment(TermKind a, TermKind b) {
  auto is = [&](TermKind x, TermKind y) { return (a == x && b == y) || (a == y && b == x); };
  auto in = [](TermKind x, std::initializer_list<TermKind> set) {
    return std::find(set.begin(), set.end(), x) != set.end();
  };
  const auto mag = {TermKind::kScale, TermKind::kNonlinearK3, TermKind::kOddQuadratic, TermKind::kGravityError,
                    TermKind::kNonlinearK2, TermKind::kBias};
  std::string A = model::term_name(a), B = model::term_name(b);
  // Two orders of one polynomial (the higher nests the lower): more levels over a wider span.
  if (a == b && model::reads_temperature(a))
    return A + " at two orders: more temperature levels over a wider span (the orders separate with the number "
           "and spread of the levels)";
  // A wrong local g is a common scale of a static design (tumbles do not help); a known input apart
  // from gravity does: the centripetal ω×(ω×r) on a rate table, the offset r known (stend gap validate).
  if (is(TermKind::kGravityError, TermKind::kLeverArm))
    return A + " vs " + B + ": remount the sensor at a second known offset from the rate axis (with one mount, g "
           "and the radius both off by the same fraction look like a common scale)";
  if (is(TermKind::kGravityError, TermKind::kScale))
    return A + " vs " + B + ": an input of known size apart from gravity — the accelerometer off the axis of a "
           "rate table (centripetal ω²r at known offsets, two mounts), or a second reference for g";
  if (in(a, mag) && in(b, mag))
    return A + " vs " + B + ": add positions where the axis sees other inputs than 0 and ±g (tilts of 30°, 45°, "
           "60° about two axes, i.e. a tumble), or a centrifuge / a second known reference for g";
  if (is(TermKind::kBiasTemperature, TermKind::kTimeDrift) || is(TermKind::kScaleTemperature, TermKind::kTimeDrift))
    return A + " vs " + B + ": visit the temperatures in a different order (down-sweep after the up-sweep) or "
           "repeat one temperature at the end";
  if (is(TermKind::kThermalLag, TermKind::kThermalHysteresis))
    return A + " vs " + B + ": ramp at two different rates, and hold long enough that dT/dt reaches 0";
  if (a == TermKind::kThermalHysteresis || b == TermKind::kThermalHysteresis)
    return A + " vs " + B + ": approach the same temperatures from above and from below";
  if (a == TermKind::kLeverArm || b == TermKind::kLeverArm)
    return A + " vs " + B + ": rate segments at several rates (centripetal grows with ω²)";
  if (in(a, {TermKind::kTableAngleOffset, TermKind::kTableAxisTilt}) ||
      in(b, {TermKind::kTableAngleOffset, TermKind::kTableAxisTilt}))
    return A + " vs " + B + ": remount the sensor rotated by 90° on the table (sensor terms move with the "
           "sensor, table terms stay with the table)";
  if (a == TermKind::kCrossAxis || b == TermKind::kCrossAxis)
    return A + " vs " + B + ": tumble positions that excite two axes at once (45° tilts)";
  if (a == TermKind::kTimeDrift || b == TermKind::kTimeDrift)
    return A + " vs " + B + ": repeat the first positions at the end of the run";
  return A + " vs " + B + ": add segments where their regressors differ (other orientations/temperatures)";
}

}  // namespace stend::diagnosis
