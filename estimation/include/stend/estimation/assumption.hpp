// Values the user states for parameters a fit did not determine — what `stend apply` and
// `stend export` need before they write a parameter the data did not give (`--assume bias_x=0`).
//
// A parameter is determined when InstrumentModel::determined says so (identified, or held at 0
// where 0 is exact). Any other parameter of a model that is to be applied or exported is refused,
// naming it and why, unless an Assumption states its value, in the parameter's unit as the results
// file stores it (ParameterEstimate::unit: SI). The value is then written into θ and recorded.
#pragma once

#include <stend/estimation/instrument_model.hpp>

#include <string>
#include <vector>

namespace stend::estimation {

struct Assumption {
  std::string name;  // "bias_x", or with its instrument "accel_bias_x" / "gyro_bias_x"
  double value = 0.0;
};

// "bias_x=0,accel_scale_y=0.001" → the assumptions; throws std::invalid_argument saying what was
// expected.
std::vector<Assumption> parse_assumptions(const std::string& text);

// Settles every parameter of `models` the fit did not determine: its θ entry is set to the value
// an assumption states (a bare name names the parameter of whichever instrument has it, in every
// model of that instrument; a prefixed one, accel_… or gyro_…, that instrument's). Returns one line
// per value used: "accelerometer bias_x = 0 m/s^2 (not identifiable: …)". Throws stend::InputError
// "SOURCE: cannot ACTION: …" listing each parameter left without a value (and the --assume that would
// set them all to 0), or naming an assumption that names no such parameter or, bare, parameters of
// both instruments.
std::vector<std::string> settle_undetermined(const std::vector<InstrumentModel*>& models,
                                             const std::vector<Assumption>& assumed, const std::string& source,
                                             const std::string& action);

}  // namespace stend::estimation
