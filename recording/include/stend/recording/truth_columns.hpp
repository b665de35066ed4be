// The truth columns that state what was applied to the sensor, in the sensor frame — written once
// here: the bench, the importers and the alignment of a recording to its procedure write them;
// processing, the estimators and the diagnosis read them (docs/recording-format.md, truth.csv).
// Held truth (io's add_held_truth, the alignment): the same values at the start, middle and end of
// a segment.
#pragma once

#include <array>
#include <initializer_list>
#include <string>
#include <vector>

namespace stend {

// Specific force on the sensor axes [m/s²]: +g along the sensor direction pointing up when still;
// NaN when the orientation is unknown.
inline constexpr std::array<const char*, 3> kSpecificForceColumns = {"f_x_mps2", "f_y_mps2", "f_z_mps2"};
// Angular rate of the sensor on its axes [rad/s]: the known rate of a rate leg; during a still at a
// known orientation the Earth rate's vertical component Ω_e·sin(latitude)·up (0 when the latitude
// is not known).
inline constexpr std::array<const char*, 3> kRateColumns = {"w_x_radps", "w_y_radps", "w_z_radps"};
// A known turn: its rotation vector (axis × angle) in the sensor frame [deg], held over the turn's
// rotation segment; NaN outside known turns.
inline constexpr std::array<const char*, 3> kTurnColumns = {"turn_x_deg", "turn_y_deg", "turn_z_deg"};

// A held mean: a row of a table of means held as an orientation segment (io's importers of tables:
// the samples repeat the row's mean, so their spread is zero by construction and says nothing about
// noise). What the table states of the noise of that mean, held over the segment like the truth:
// the number of samples averaged, and their standard deviation per axis [m/s²]; NaN where the table
// does not state it. Their presence marks the recording as a table of means (processing: the
// segments are the static points, and this spread, not the samples', is their noise).
inline constexpr const char* kHeldCountColumn = "held_n";
inline constexpr std::array<const char*, 3> kHeldSigmaColumns = {"held_sigma_x_mps2", "held_sigma_y_mps2",
                                                                  "held_sigma_z_mps2"};

// The names of `groups`, in order, as a list: truth_column_names({kSpecificForceColumns, kRateColumns}).
inline std::vector<std::string> truth_column_names(std::initializer_list<std::array<const char*, 3>> groups) {
  std::vector<std::string> out;
  for (const auto& g : groups) out.insert(out.end(), g.begin(), g.end());
  return out;
}

// The held-mean columns in order: kHeldCountColumn, then kHeldSigmaColumns.
inline std::vector<std::string> held_column_names() {
  std::vector<std::string> out = {kHeldCountColumn};
  out.insert(out.end(), kHeldSigmaColumns.begin(), kHeldSigmaColumns.end());
  return out;
}

}  // namespace stend
