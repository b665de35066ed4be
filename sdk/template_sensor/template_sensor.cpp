// template_sensor — an ideal accelerometer with a constant bias: the smallest real Stend sensor.
//
// It reads the specific force the bench applies (truth.specific_force_mps2, sensor frame), adds
// a configurable bias, scales, quantises to whole counts of `lsb_mps2` and clips at ±range.
// Samples come at `rate_hz` on the run clock. Replace acquire() with reads from your device to
// make it a driver for real hardware (see README.md).
#include <stend/sdk.hpp>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// The configuration schema. The host checks an experiment's `config:` block against it (type,
// unit, range, choices, unknown keys) and fills in defaults, so the constructor below always
// receives every key with the declared type.
//   {key, type, unit, default (YAML text, or nullptr = required), min, max, choices, doc}
const stend_param_spec kParams[] = {
    {"rate_hz", "number", "Hz", "100", 1.0, 10000.0, nullptr, "output data rate"},
    {"bias_mps2", "vec3", "m/s^2", "[0, 0, 0]", -50.0, 50.0, nullptr,
     "constant bias added to each axis"},
    {"scale", "number", "1", "1.0", 0.5, 2.0, nullptr, "scale factor applied to force + bias"},
    {"range_mps2", "number", "m/s^2", "156.9064", 1.0, 2000.0, nullptr,
     "full scale, +-; readings beyond it are clipped and flagged"},
    {"lsb_mps2", "number", "m/s^2", "0.0047884", 1e-9, 1.0, nullptr, "value of one count"},
    {"serial", "string", "", "TS-0001", NAN, NAN, nullptr, "serial number reported"},
};

class TemplateSensor final : public stend::Sensor {
 public:
  explicit TemplateSensor(const stend::Params& p)
      : rate_hz_(p.number("rate_hz")),
        bias_mps2_(p.vec3("bias_mps2")),
        scale_(p.number("scale")),
        range_mps2_(p.number("range_mps2")),
        lsb_mps2_(p.number("lsb_mps2")),
        serial_(p.string("serial")) {
    // Checks across keys (the schema checks each key alone). Throwing here makes the host report
    // "plugin 'template_sensor' (FILE) could not create a sensor: <this text>".
    if (range_mps2_ / lsb_mps2_ > 2147483647.0) {
      throw std::invalid_argument("range_mps2 / lsb_mps2 exceeds a 32-bit count");
    }
  }

  stend::SensorIdentity identity() const override {
    return {"Stend", "TemplateSensor", serial_, ""};
  }

  stend::SensorInfo info() const override {
    stend::SensorInfo i;
    i.output_rate_hz = rate_hz_;
    i.accel_range_mps2 = range_mps2_;
    i.accel_lsb_mps2 = lsb_mps2_;
    i.has_gyro = false;
    i.has_temperature = false;
    return i;
  }

  void start(double t0_s) override {
    t0_s_ = t0_s;
    next_index_ = 1;  // the first sample is strictly after t0
    started_ = true;
  }

  void acquire(double t_s, const stend::TruthSource& truth,
               std::vector<stend::ImuSample>& out) override {
    if (!started_) throw std::runtime_error("template_sensor: acquire() before start()");
    // Sample times are computed from an index, not accumulated, so they never drift.
    for (;;) {
      const double t = t0_s_ + static_cast<double>(next_index_) / rate_hz_;
      if (t > t_s + 1e-9) break;
      out.push_back(sample_at(t, truth.at(t)));
      ++next_index_;
    }
  }

  void stop() override { started_ = false; }

 private:
  stend::ImuSample sample_at(double t, const stend::BenchTruth& truth) const {
    stend::ImuSample s;
    s.t_s = t;
    const Eigen::Vector3d value = scale_ * (truth.specific_force_mps2 + bias_mps2_);
    const double max_counts = std::floor(range_mps2_ / lsb_mps2_);
    for (int k = 0; k < 3; ++k) {
      double counts = std::nearbyint(value[k] / lsb_mps2_);
      if (std::abs(counts) > max_counts) {
        counts = std::copysign(max_counts, counts);
        s.flags |= stend::kAccelSaturated;
      }
      s.accel_counts[k] = static_cast<std::int32_t>(counts);
      s.accel_mps2[k] = counts * lsb_mps2_;
    }
    return s;
  }

  double rate_hz_;
  Eigen::Vector3d bias_mps2_;
  double scale_, range_mps2_, lsb_mps2_;
  std::string serial_;
  double t0_s_ = 0.0;
  std::int64_t next_index_ = 1;
  bool started_ = false;
};

}  // namespace

// The entry point: kind, name (what experiments write after `plugin:`), version, one-line
// description, schema, and the class to construct from the validated Params.
STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "template_sensor", "0.1.0",
                    "Ideal accelerometer with a constant bias (template for new sensors)",
                    kParams, TemplateSensor)
