// TruthCell: the stimulus an emulated sensor sits in, changeable while the emulator runs.
#pragma once

#include <stend/sdk.hpp>

#include <mutex>

namespace stend::emu {

// Thread-safe truth holder for emulators whose stimulus changes while they run (a test or a
// bench-world emulator sets it; the sensor models read it at each sample instant).
class TruthCell {
 public:
  explicit TruthCell(BenchTruth t = {}) : t_(t) {}
  void set(const BenchTruth& t) {
    std::lock_guard<std::mutex> lock(m_);
    t_ = t;
  }
  BenchTruth at(double t_s) const {
    std::lock_guard<std::mutex> lock(m_);
    BenchTruth b = t_;
    b.t_s = t_s;
    return b;
  }

 private:
  mutable std::mutex m_;
  BenchTruth t_;
};

}  // namespace stend::emu
