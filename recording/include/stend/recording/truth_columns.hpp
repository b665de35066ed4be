// The truth columns that state what was applied to the sensor, in the sensor frame — written once
// here: the bench, the importers and the alignment of a recording to its procedure write them;
// processing, the estimators and the diagnosis read them (docs/recording-format.md, truth.csv).
#pragma once

#include <array>

namespace stend {

// Specific force on the sensor axes [m/s²]: +g along the sensor direction pointing up when still.
inline constexpr std::array<const char*, 3> kSpecificForceColumns = {"f_x_mps2", "f_y_mps2", "f_z_mps2"};
// Angular rate of the sensor on its axes [rad/s].
inline constexpr std::array<const char*, 3> kRateColumns = {"w_x_radps", "w_y_radps", "w_z_radps"};
// A known turn: its rotation vector (axis × angle) in the sensor frame [deg], held over the turn's
// rotation segment; NaN outside known turns.
inline constexpr std::array<const char*, 3> kTurnColumns = {"turn_x_deg", "turn_y_deg", "turn_z_deg"};

}  // namespace stend
