// The noise of each sensor channel (see stend/estimation/noise.hpp).
#include "stend/estimation/noise.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <ostream>

namespace stend::estimation {

bool ChannelNoise::equals(const ChannelNoise& o, double rel_tol, double abs_tol) const {
  return channel == o.channel && instrument == o.instrument && axis == o.axis &&
         white_noise.equals(o.white_noise, rel_tol, abs_tol) && random_walk.equals(o.random_walk, rel_tol, abs_tol) &&
         bias_instability.equals(o.bias_instability, rel_tol, abs_tol);
}

const ChannelNoise* NoiseResult::find(model::Instrument instrument, int axis) const {
  for (const auto& c : channels)
    if (c.instrument == instrument && c.axis == axis) return &c;
  return nullptr;
}

bool NoiseResult::any_identified() const {
  return std::any_of(channels.begin(), channels.end(), [](const ChannelNoise& c) {
    return c.white_noise.identifiable || c.random_walk.identifiable || c.bias_instability.identifiable;
  });
}

void NoiseResult::print(std::ostream& os) const {
  os << fmt::format("noise: {} channels, {} Hz, {} samples\n", channels.size(), number_text(rate_hz), samples);
  for (const auto& c : channels)
    for (const ParameterEstimate* p : {&c.white_noise, &c.random_walk, &c.bias_instability}) os << *p << "\n";
  for (const auto inst : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope}) {
    const SensorNoise& s = sensor(inst);
    for (const auto& [what, d] : {std::pair{"N", &s.white_noise}, {"K", &s.random_walk}})
      if (std::isfinite(d->value))
        os << fmt::format("{} {} of the sensor when no axis identifies it: {} ({})\n",
                          inst == model::Instrument::kAccelerometer ? "accelerometer" : "gyroscope", what,
                          number_text(d->value), d->upper_bound ? "upper bound" : "slope read-off");
  }
}

std::ostream& operator<<(std::ostream& os, const NoiseResult& n) {
  n.print(os);
  return os;
}

bool NoiseResult::equals(const NoiseResult& o, double rel_tol, double abs_tol) const {
  if (channels.size() != o.channels.size() || samples != o.samples || !nearly_equal(rate_hz, o.rate_hz, rel_tol, abs_tol))
    return false;
  for (std::size_t i = 0; i < channels.size(); ++i)
    if (!channels[i].equals(o.channels[i], rel_tol, abs_tol)) return false;
  for (std::size_t i = 0; i < sensors.size(); ++i)
    for (const auto& [a, b] : {std::pair{&sensors[i].white_noise, &o.sensors[i].white_noise},
                               {&sensors[i].random_walk, &o.sensors[i].random_walk}})
      if (a->upper_bound != b->upper_bound || !nearly_equal(a->value, b->value, rel_tol, abs_tol)) return false;
  return true;
}

}  // namespace stend::estimation
