// template_sensor — an ideal accelerometer with a constant bias: the smallest real Stend sensor.
//
// It reads the specific force the bench applies (truth.specific_force_mps2, sensor frame), adds
// a configurable bias, scales, quantises to whole counts of `lsb_mps2` and clips at ±range.
// Samples come at `rate_hz` on the run clock. Replace acquire() with reads from your device to
// make it a driver for real hardware (see README.md).
#include <stend/fields.hpp>
#include <stend/sdk.hpp>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// The configuration: one member per `config:` key, each default written here and nowhere else.
struct TemplateConfig {
  double rate_hz = 100.0;                               // Hz
  Eigen::Vector3d bias_mps2 = Eigen::Vector3d::Zero();  // m/s^2, sensor frame
  double scale = 1.0;                                   // dimensionless
  double range_mps2 = 156.9064;                         // m/s^2 (16 g)
  double lsb_mps2 = 0.0047884;                          // m/s^2 per count
  std::string serial = "TS-0001";
};

// The field table: one declaration per key — key, member, unit, doc, then optionally
// .range(min, max), .at_least(min), .choices("a|b|c") or .required() (no default). From it Stend
// makes the schema the host checks an experiment's `config:` block against (type from the
// member, unit, range, choices, unknown keys, with file:line:column; defaults filled in from
// TemplateConfig{}) and the reader the constructor below calls.
const stend::fields::Table<TemplateConfig>& template_fields() {
  using C = TemplateConfig;
  using F = stend::fields::Field<C>;
  static const stend::fields::Table<C> table("template_sensor", {
      F("rate_hz", &C::rate_hz, "Hz", "output data rate").range(1.0, 10000.0),
      F("bias_mps2", &C::bias_mps2, "m/s^2", "constant bias added to each axis").range(-50.0, 50.0),
      F("scale", &C::scale, "1", "scale factor applied to force + bias").range(0.5, 2.0),
      F("range_mps2", &C::range_mps2, "m/s^2", "full scale, +-; readings beyond it are clipped and flagged")
          .range(1.0, 2000.0),
      F("lsb_mps2", &C::lsb_mps2, "m/s^2", "value of one count").range(1e-9, 1.0),
      F("serial", &C::serial, "", "serial number reported"),
  });
  return table;
}

class TemplateSensor final : public stend::Sensor {
 public:
  explicit TemplateSensor(const stend::Params& p) : c_(template_fields().read(p)) {
    // Checks across keys (the schema checks each key alone). Throwing here makes the host report
    // "plugin 'template_sensor' (FILE) could not create a sensor: <this text>".
    if (c_.range_mps2 / c_.lsb_mps2 > 2147483647.0) {
      throw std::invalid_argument("range_mps2 / lsb_mps2 exceeds a 32-bit count");
    }
  }

  stend::SensorIdentity identity() const override {
    return {"Stend", "TemplateSensor", c_.serial, ""};
  }

  stend::SensorInfo info() const override {
    stend::SensorInfo i;
    i.output_rate_hz = c_.rate_hz;
    i.accel_range_mps2 = c_.range_mps2;
    i.accel_lsb_mps2 = c_.lsb_mps2;
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
      const double t = t0_s_ + static_cast<double>(next_index_) / c_.rate_hz;
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
    const Eigen::Vector3d value = c_.scale * (truth.specific_force_mps2 + c_.bias_mps2);
    const double max_counts = std::floor(c_.range_mps2 / c_.lsb_mps2);
    for (int k = 0; k < 3; ++k) {
      double counts = std::nearbyint(value[k] / c_.lsb_mps2);
      if (std::abs(counts) > max_counts) {
        counts = std::copysign(max_counts, counts);
        s.flags |= stend::kAccelSaturated;
      }
      s.accel_counts[k] = static_cast<std::int32_t>(counts);
      s.accel_mps2[k] = counts * c_.lsb_mps2;
    }
    return s;
  }

  TemplateConfig c_;
  double t0_s_ = 0.0;
  std::int64_t next_index_ = 1;
  bool started_ = false;
};

}  // namespace

// The entry point: kind, name (what experiments write after `plugin:`), version, one-line
// description, schema (the field table), and the class to construct from the validated Params.
STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "template_sensor", "0.1.0",
                    "Ideal accelerometer with a constant bias (template for new sensors)",
                    template_fields(), TemplateSensor)
