// Calibrates an accelerometer from a public session and prints the report.
//   stend_ceres_calibrate imucal  <annotated_session.csv>   [--json]   (known orientations, 6 positions)
//   stend_ceres_calibrate mpu6050 <calibration_session.csv> [--json]   (unknown orientations, |g| only)
#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/io/importers.hpp>

#include <cstring>
#include <iostream>
#include <string>

using namespace stend;
using namespace stend::ceres_nonlinear;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: " << argv[0] << " <imucal|mpu6050> <file.csv> [--json]\n";
    return 2;
  }
  const std::string kind = argv[1];
  const bool json = argc > 3 && std::strcmp(argv[3], "--json") == 0;
  try {
    CalibrationResult r;
    if (kind == "imucal") {
      const Recording rec = io::import_imucal_session(argv[2]);
      const double g = rec.header.gravity_mps2;  // imucal's expected_g, as the importer states it
      std::vector<processing::StaticPoint> ivs;
      std::vector<Eigen::Vector3d> truth;
      processing::ProcessingOptions segments = default_interval_options();
      segments.intervals = processing::IntervalSource::kSegments;
      segments.extraction.settle_s = 0.5;  // dropped at each end of a segment
      for (const auto& iv : static_intervals(rec, segments)) {
        // x_p: x axis up → the accelerometer reads +g on x; x_a: down → −g.
        Eigen::Vector3d f = Eigen::Vector3d::Zero();
        f[iv.segment.label[0] - 'x'] = (iv.segment.label[2] == 'p' ? 1.0 : -1.0) * g;
        ivs.push_back(iv);
        truth.push_back(f);
      }
      CalibrationOptions o;
      o.gravity_mps2 = g;
      o.orientation_sigma_deg = 1.0;   // hand-placed positions: ~1° tilts
      r = calibrate_accelerometer_known_orientations(ivs, truth, o);
    } else if (kind == "mpu6050") {
      const Recording rec = io::import_mpu6050_multipos(argv[2]);
      CalibrationOptions o;
      o.gravity_mps2 = 9.81;  // the g of the session's reference calibration (README, "Figures")
      o.processing.detector.init_duration_s = 30.0;
      r = calibrate_accelerometer_unknown_orientations(rec, o);
    } else {
      std::cerr << "unknown session kind '" << kind << "' (imucal or mpu6050)\n";
      return 2;
    }
    std::cout << (json ? r.to_json() : r.report()) << "\n";
    return r.ok() ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
