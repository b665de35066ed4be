// The Allan curve of one channel and its analysis: units, options, octave points with their
// intervals, the noise model fitted. See stend/noise/noise_model.hpp.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stend/noise/noise_model.hpp"
#include "stend/physics/units.hpp"

namespace stend::noise {

const char* to_string(Instrument i) {
  switch (i) {
    case Instrument::kAccelerometer: return "accelerometer";
    case Instrument::kGyroscope: return "gyroscope";
    case Instrument::kOther: return "other";
  }
  return "?";
}

Units units_for(Instrument instrument, const std::string& signal_unit) {
  Units u;
  switch (instrument) {
    case Instrument::kAccelerometer:
      if (signal_unit.empty() || signal_unit == "m/s^2") {
        return {"m/s^2", "m/s", "m/s^2/sqrt(Hz)", "m/s^2", "m/s^3/sqrt(Hz)", "m/s^3", "m/s^2"};
      }
      break;
    case Instrument::kGyroscope:
      if (signal_unit.empty() || signal_unit == "rad/s") {
        return {"rad/s", "rad", "rad/s/sqrt(Hz)", "rad/s", "rad/s^2/sqrt(Hz)", "rad/s^2", "rad/s"};
      }
      break;
    case Instrument::kOther: break;
  }
  const std::string s = signal_unit.empty() ? "unit" : signal_unit;
  return {s, s + "*s", s + "/sqrt(Hz)", s, s + "/s/sqrt(Hz)", s + "/s", s};
}

bool AnalysisOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (max_m < 1) return fail("max_m: must be an integer >= 1 (samples)");
  if (!(confidence > 0.0 && confidence < 1.0)) return fail("confidence: must be in (0, 1), e.g. 0.683 or 0.95");
  if (!(slope_tolerance > 0.0 && slope_tolerance < 0.5)) return fail("slope_tolerance: must be in (0, 0.5)");
  if (!(min_readoff_edf >= 0.0)) return fail("min_readoff_edf: must be >= 0");
  if (min_readoff_points < 1 || min_readoff_points > 64) return fail("min_readoff_points: must be an integer in 1 … 64");
  if (lowpass_hz < 0.0) return fail("lowpass_hz: must be >= 0 (Hz; 0 = no output filter) or .nan (not stated)");
  return true;
}

AllanCurve make_curve(const std::vector<OctaveVariance>& octaves, std::uint64_t samples,
                      double rate_hz, const ChannelInfo& channel, double confidence) {
  if (!(rate_hz > 0.0)) throw std::invalid_argument("Allan curve: the sample rate must be > 0");
  AllanCurve c;
  c.channel = channel;
  c.units = units_for(channel.instrument, channel.unit);
  if (c.channel.unit.empty()) c.channel.unit = c.units.signal;
  c.rate_hz = rate_hz;
  c.samples = samples;
  c.confidence = confidence;
  for (const auto& o : octaves) {
    AllanPoint p;
    p.m = o.m;
    p.terms = o.terms;
    p.tau_s = static_cast<double>(o.m) / rate_hz;
    p.avar = o.avar;
    p.adev = std::sqrt(std::max(0.0, o.avar));
    c.points.push_back(p);
  }
  assign_intervals(c, nullptr);
  return c;
}

void assign_intervals(AllanCurve& curve, const NoiseModel* model) {
  const double n_phase = static_cast<double>(curve.samples) + 1.0;
  for (auto& p : curve.points) {
    p.noise = model && model->ok ? model->dominant(p.tau_s) : NoiseType::kWhite;
    p.edf = edf_overlapping_adev(p.noise, n_phase, static_cast<double>(p.m));
    const auto ci = deviation_interval(p.adev, p.edf, curve.confidence);
    p.adev_lo = ci.lo;
    p.adev_hi = ci.hi;
  }
}

ChannelResult analyze(const OverlappingAllanStream& stream, double rate_hz,
                      const ChannelInfo& channel, const AnalysisOptions& options) {
  ChannelResult r;
  r.curve = make_curve(stream.octaves(), stream.samples(), rate_hz, channel, options.confidence);
  r.model = fit_noise_model(r.curve, options);
  if (options.edf_from_model && r.model.ok) assign_intervals(r.curve, &r.model);
  return r;
}

ChannelResult analyze(const double* y, std::size_t n, std::size_t stride, double rate_hz,
                      const ChannelInfo& channel, const AnalysisOptions& options) {
  OverlappingAllanStream s(options.max_m, n);
  s.add(y, n, stride == 0 ? 1 : stride);
  return analyze(s, rate_hz, channel, options);
}

const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::kIdentified: return "identified";
    case Verdict::kUpperBound: return "upper_bound";
    case Verdict::kFailed: return "failed";
  }
  return "?";
}

std::vector<Conversion> datasheet_units(const Coefficient& c, Instrument instrument) {
  const std::string s = c.symbol;
  const bool gyro = instrument == Instrument::kGyroscope, accel = instrument == Instrument::kAccelerometer;
  const double deg = physics::kRadToDeg;
  if (s == "N" && gyro) return {{deg * 60.0, "deg/sqrt(h)"}, {deg, "deg/s/sqrt(Hz)"}};
  if (s == "N" && accel) return {{60.0, "m/s/sqrt(h)"}, {1.0 / physics::kMicroG, "ug/sqrt(Hz)"}};
  if ((s == "B" || s == "G") && gyro) return {{1.0 / physics::kDegPerHour, "deg/h"}};
  if ((s == "B" || s == "G") && accel) return {{1.0 / physics::kMicroG, "ug"}};
  // K [unit/s/√Hz] = [unit/√s]: per √s and per √h (× 60).
  if (s == "K" && gyro) return {{deg, "deg/s/sqrt(s)"}, {deg * 3600.0 * 60.0, "deg/h/sqrt(h)"}};
  if (s == "K" && accel) return {{1.0 / physics::kMicroG, "ug/sqrt(s)"}, {60.0 / physics::kMicroG, "ug/sqrt(h)"}};
  return {};
}

}  // namespace stend::noise
