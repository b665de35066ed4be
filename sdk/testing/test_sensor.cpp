// Working C++ test sensors built with the SDK macro:
//   STEND_TEST_GOOD          -> "test_good": reads truth.specific_force_mps2 + `offset_mps2`
//   STEND_TEST_CREATE_FAILS  -> "test_create_fails": its constructor throws with a reason
//   STEND_TEST_MARKER        -> "test_marker": test_good whose library, when loaded, appends a
//                               line to the file $STEND_TEST_MARKER_FILE (shows that its code ran)
#include <stend/sdk.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace {

const stend_param_spec kParams[] = {
    {"rate_hz", "number", "Hz", "100", 1.0, 1000.0, nullptr, "output data rate"},
    {"offset_mps2", "vec3", "m/s^2", "[0, 0, 0]", -100.0, 100.0, nullptr, "added to every reading"},
    {"device", "string", "", "sim", NAN, NAN, "sim|none", "which device to open"},
};

class TestSensor final : public stend::Sensor {
 public:
  explicit TestSensor(const stend::Params& p)
      : rate_hz_(p.number("rate_hz")), offset_(p.vec3("offset_mps2")) {
#if defined(STEND_TEST_CREATE_FAILS)
    throw std::runtime_error("no device at /dev/stend-test-does-not-exist (device '" +
                             p.string("device") + "')");
#endif
  }
  stend::SensorIdentity identity() const override { return {"Stend", "TestSensor", "T-1", "0x00"}; }
  stend::SensorInfo info() const override {
    stend::SensorInfo i;
    i.output_rate_hz = rate_hz_;
    i.accel_range_mps2 = 1000.0;
    i.accel_lsb_mps2 = 1e-6;
    i.has_gyro = false;
    i.has_temperature = false;
    return i;
  }
  void start(double t0_s) override {
    t0_s_ = t0_s;
    next_ = 1;
  }
  void acquire(double t_s, const stend::TruthSource& truth,
               std::vector<stend::ImuSample>& out) override {
    for (;;) {
      const double t = t0_s_ + static_cast<double>(next_) / rate_hz_;
      if (t > t_s + 1e-9) break;
      stend::ImuSample s;
      s.t_s = t;
      s.accel_mps2 = truth.at(t).specific_force_mps2 + offset_;
      out.push_back(s);
      ++next_;
    }
  }

 private:
  double rate_hz_;
  Eigen::Vector3d offset_;
  double t0_s_ = 0.0;
  long next_ = 1;
};

#if defined(STEND_TEST_MARKER)
// Runs at dlopen, before any entry point is called.
[[maybe_unused]] const bool kMarked = [] {
  if (const char* file = std::getenv("STEND_TEST_MARKER_FILE")) std::ofstream(file, std::ios::app) << "loaded\n";
  return true;
}();
#endif

}  // namespace

#if defined(STEND_TEST_MARKER)
STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "test_marker", "0.0.1", "test sensor whose library leaves a mark when loaded",
                    kParams, TestSensor)
#elif defined(STEND_TEST_CREATE_FAILS)
STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "test_create_fails", "0.0.1",
                    "test sensor whose construction fails", kParams, TestSensor)
#else
STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "test_good", "1.2.3", "test sensor: truth plus an offset",
                    kParams, TestSensor)
#endif
