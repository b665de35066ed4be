// A fit of a twin log against the truth the twin planted: each parameter of a results document's
// flat list (ceres.json's `parameters`: name, value, 95 % interval, `fixed`, verdict) checked
// against the planted value of the same name (stend/sim/procedure_player.hpp, PlantedTruth). A fit
// with the accelerometer's orientations unknown (`options.accelerometer: unknown_orientations`) is
// compared in that fit's frame convention (PlantedTruth::in_accel_frame_convention).
#pragma once

#include <stend/sim/procedure_player.hpp>

#include <string>
#include <vector>

namespace stend::sim {

struct ParameterCheck {
  std::string name;
  double planted = 0.0;
  double value = 0.0, std_error = 0.0, lower = 0.0, upper = 0.0;  // NaN when the fit gives none
  bool estimated = false;  // a finite value and interval, not held: the fit identifies it
  bool held = false;       // held (fixed) by the fit, with its reason: not invented
  bool covered = false;    // estimated and lower <= planted <= upper
  std::string verdict, reason;
  // (value − planted) / std_error; NaN when not estimated.
  double z() const;
  // planted inside the interval widened about the value by `factor`.
  bool covered_within(double factor) const;
};

// The parameters of `results_json` (a ceres.json document) that the planted truth names, in the
// document's order. Throws std::runtime_error when the document has no `parameters` list.
std::vector<ParameterCheck> check_against_truth(const std::string& results_json, const PlantedTruth& truth);

}  // namespace stend::sim
