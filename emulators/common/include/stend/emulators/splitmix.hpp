// The emulators' fault-injection random stream: splitmix64 (Steele, Lea & Flood), one 64-bit state
// per emulator seeded from its config. Cheap and reproducible; not for the physics (that draws from
// stend::model::Rng). Not thread-safe: one stream per server thread.
#pragma once

#include <cstdint>

namespace stend::emu {

// Next 64 random bits; advances `state`.
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) from the top 53 bits of one draw.
inline double splitmix_unit(std::uint64_t& state) { return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53; }

}  // namespace stend::emu
