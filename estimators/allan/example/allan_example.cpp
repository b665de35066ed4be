// Allan analysis of an imported recording: prints the per-axis curves, the noise model, the
// summary table and Kalibr's imu.yaml block (or JSON with --json).
//
//   stend_allan_example [--json] [--kalibr] [--t0 S] [--t1 S] <file> [format]
//
// format: mpu6050 (default; the tomisuarez2/ImuCalibration CSV layout), imucal.
// Example (the figures in README.md):
//   stend_allan_example ../shared/data/mpu6050_multipos/static_449s.csv
#include <stend/allan/allan.hpp>
#include <stend/io/importers.hpp>

#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  bool json = false, kalibr_only = false;
  std::string file, format = "mpu6050";
  stend::allan::AllanOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json") {
      json = true;
    } else if (a == "--kalibr") {
      kalibr_only = true;
    } else if ((a == "--t0" || a == "--t1") && i + 1 < argc) {
      (a == "--t0" ? options.t_begin_s : options.t_end_s) = std::strtod(argv[++i], nullptr);
    } else if (a == "-h" || a == "--help") {
      std::cout << "usage: stend_allan_example [--json] [--kalibr] [--t0 S] [--t1 S] <file> "
                   "[mpu6050|imucal]\n";
      return 0;
    } else if (file.empty()) {
      file = a;
    } else {
      format = a;
    }
  }
  if (file.empty()) {
    std::cerr << "stend_allan_example: give a file (see --help)\n";
    return 2;
  }
  try {
    stend::Recording rec;
    if (format == "mpu6050") {
      rec = stend::io::import_mpu6050_multipos(file);
    } else if (format == "imucal") {
      rec = stend::io::import_imucal_session(file);
    } else {
      std::cerr << "stend_allan_example: unknown format '" << format << "' (mpu6050, imucal)\n";
      return 2;
    }
    const auto report = stend::allan::analyze_recording(rec, options);
    if (json) {
      stend::allan::write_json(std::cout, report);
    } else if (kalibr_only) {
      stend::allan::write_kalibr_yaml(std::cout, report.kalibr);
    } else {
      std::cout << report;
    }
  } catch (const std::exception& e) {
    std::cerr << "stend_allan_example: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
