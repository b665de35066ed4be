// Wall-clock instants of the emulators' fault switches (silence, disconnection), as steady_clock
// nanoseconds in one std::atomic<std::int64_t>, so that any thread may set them while the server
// thread reads them.
#pragma once

#include <chrono>
#include <cstdint>

namespace stend::emu {

// steady_clock now [ns since its epoch].
inline std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// steady_clock now + d [ns since its epoch]: the end of a fault period that starts now.
inline std::int64_t steady_ns_after(std::chrono::milliseconds d) {
  return steady_now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

}  // namespace stend::emu
