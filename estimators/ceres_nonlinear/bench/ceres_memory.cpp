// Peak resident memory (VmHWM from /proc/self/status) of the whole multi-position process
// (detection + accelerometer fit + gyro integration fit + covariances) on a synthetic record:
//   stend_ceres_memory SAMPLES [POSITIONS=38]
// Prints the peak before the fit (the record itself) and after, in MiB, and the fit status.
#include "synthetic_record.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

using namespace stend::ceres_nonlinear;

namespace {
double vm_hwm_mib() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  return -1.0;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s SAMPLES [POSITIONS]\n", argv[0]);
    return 2;
  }
  synthetic::Spec spec;
  spec.samples = std::strtoull(argv[1], nullptr, 10);
  if (argc > 2) spec.positions = std::atoi(argv[2]);
  const double base = vm_hwm_mib();
  const synthetic::Record r = synthetic::make(spec);
  const double with_record = vm_hwm_mib();
  CalibrationOptions o;
  o.processing.detector.trim_s = 0.5;
  o.processing.detector.max_gyro_radps = 0.05;
  const auto t0 = std::chrono::steady_clock::now();
  const CalibrationResult a = calibrate_accelerometer_unknown_orientations(r.recording, o);
  const CalibrationResult g = calibrate_gyro_integration(r.recording, a);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double peak = vm_hwm_mib();
  std::printf("samples %zu positions %d intervals %zu: accel %s, gyro %s; %.3f s; VmHWM start %.1f MiB, with record "
              "%.1f MiB, after fit %.1f MiB (fit adds %.1f MiB)\n",
              r.recording.samples.size(), spec.positions, a.intervals.size(), a.ok() ? "ok" : a.message.c_str(),
              g.ok() ? "ok" : g.message.c_str(), secs, base, with_record, peak, peak - with_record);
  return a.ok() && g.ok() ? 0 : 1;
}
