// The run report's overview of the recording (see overview_section.hpp).
#include "overview_section.hpp"

#include "stend/model/terms.hpp"
#include "stend/physics/units.hpp"
#include "stend/recording/instruments.hpp"
#include "stend/recording/recording.hpp"
#include "stend/recording/samples.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace stend::reporting::detail {

namespace {

using estimation::figure::palette;
using estimation::figure::Plot;
using estimation::figure::Series;
using estimation::figure::Style;

// The recording's channels reduced to kOverviewBins time bins: per bin the minimum, maximum and
// mean of each channel (ax ay az [m/s²], gx gy gz [rad/s], temperature [°C]), so that a run of any
// length is drawn with a fixed number of points, read a chunk at a time.
constexpr std::size_t kOverviewBins = 400;
constexpr std::array<Channel, 7> kOverviewChannels = {Channel::kAx, Channel::kAy, Channel::kAz, Channel::kGx,
                                                      Channel::kGy, Channel::kGz, Channel::kTemperature};
constexpr std::size_t kTemperatureChannel = 6;  // in kOverviewChannels

struct Overview {
  double t0 = 0.0, t1 = 0.0;  // [s]
  std::array<std::vector<double>, kOverviewChannels.size()> lo, hi, sum;
  std::vector<double> count;
};

Overview overview_of(const Recording& rec) {
  Overview ov;
  const SampleSource& src = rec.sample_source();
  if (src.size() == 0) return ov;
  ov.t0 = time_at(src, 0);
  ov.t1 = time_at(src, src.size() - 1);
  for (std::size_t c = 0; c < kOverviewChannels.size(); ++c) {
    ov.lo[c].assign(kOverviewBins, INFINITY);
    ov.hi[c].assign(kOverviewBins, -INFINITY);
    ov.sum[c].assign(kOverviewBins, 0.0);
  }
  ov.count.assign(kOverviewBins, 0.0);
  const double span = std::max(ov.t1 - ov.t0, 1e-9);
  for_each_chunk(src, [&](const ImuSample* chunk, std::size_t n, std::uint64_t) {
    for (std::size_t i = 0; i < n; ++i) {
      const double f = (chunk[i].t_s - ov.t0) / span * static_cast<double>(kOverviewBins);
      const auto b = static_cast<std::size_t>(std::clamp(f, 0.0, static_cast<double>(kOverviewBins - 1)));
      ov.count[b] += 1.0;
      for (std::size_t c = 0; c < kOverviewChannels.size(); ++c) {
        const double v = value_of(chunk[i], kOverviewChannels[c]);
        ov.lo[c][b] = std::min(ov.lo[c][b], v);
        ov.hi[c][b] = std::max(ov.hi[c][b], v);
        ov.sum[c][b] += v;
      }
    }
  });
  return ov;
}

// One overview plot: channels c0 … c0+n−1 scaled by `scale`, each a min–max band and a mean line
// over time, with the recording's segments shaded behind them.
Plot overview_plot(const Overview& ov, const Recording& rec, std::size_t c0, std::size_t n, double scale,
                   const std::string& title, const std::string& y_label, const std::vector<std::string>& names) {
  Plot p;
  p.title = title;
  p.x_label = "time since the start of the recording [s]";
  p.y_label = y_label;
  p.width = 760;
  p.height = 300;
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t c = c0; c < c0 + n; ++c)
    for (std::size_t b = 0; b < kOverviewBins; ++b)
      if (ov.count[b] > 0 && std::isfinite(ov.lo[c][b]) && std::isfinite(ov.hi[c][b])) {
        lo = std::min(lo, ov.lo[c][b] * scale);
        hi = std::max(hi, ov.hi[c][b] * scale);
      }
  if (!(hi >= lo)) return p;
  // Segments: shaded over the channels' range, alternating two greys so neighbours stay apart.
  for (std::size_t k = 0; k < rec.segments.size(); ++k) {
    const Segment& sg = rec.segments[k];
    Series sh{k == 0 ? "segment (shaded)" : "", Style::kBand, {}, {}, {}, {}, k % 2 ? "#999" : "#666", false, 0.12};
    sh.x = {sg.t_start_s - ov.t0, sg.t_end_s - ov.t0};
    sh.y_lo = {lo, lo};
    sh.y_hi = {hi, hi};
    p.series.push_back(sh);
  }
  const double bin_s = (ov.t1 - ov.t0) / static_cast<double>(kOverviewBins);
  for (std::size_t c = c0; c < c0 + n; ++c) {
    const std::string color = palette(c - c0);
    Series band{"", Style::kBand, {}, {}, {}, {}, color, false, 0.25};
    Series mean{names[c - c0], Style::kLine, {}, {}, {}, {}, color, false, 1.0};
    for (std::size_t b = 0; b < kOverviewBins; ++b) {
      const double t = (static_cast<double>(b) + 0.5) * bin_s;
      const bool any = ov.count[b] > 0 && std::isfinite(ov.lo[c][b]);
      band.x.push_back(t);
      band.y_lo.push_back(any ? ov.lo[c][b] * scale : kNaN);
      band.y_hi.push_back(any ? ov.hi[c][b] * scale : kNaN);
      mean.x.push_back(t);
      mean.y.push_back(any ? ov.sum[c][b] / ov.count[b] * scale : kNaN);
    }
    p.series.push_back(band);
    p.series.push_back(mean);
  }
  return p;
}

// Whether the recording has a temperature: some finite temperature sample.
bool has_temperature(const Overview& ov) {
  constexpr std::size_t t = kTemperatureChannel;
  for (std::size_t b = 0; b < ov.count.size(); ++b)  // no bins: no samples
    if (ov.count[b] > 0 && std::isfinite(ov.lo[t][b]) && std::isfinite(ov.hi[t][b])) return true;
  return false;
}

}  // namespace

estimation::ReportSection overview_section(const std::filesystem::path& dir, bool& temperature_recorded) {
  estimation::ReportSection s;
  s.heading = "Recording overview";
  s.file = "run samples";
  try {
    const Recording rec = Recording::open(dir, SampleLoading::kStream, TruthLoading::kSkip);
    const Overview ov = overview_of(rec);
    if (ov.count.empty()) {
      temperature_recorded = false;
      s.add_text("The recording has no samples.", estimation::Emphasis::kWarning);
      return s;
    }
    temperature_recorded = rec.header.info.has_temperature && has_temperature(ov);
    const std::string cap = fmt::format("Raw samples over the whole recording ({} samples, {} s): each channel's "
                                        "minimum–maximum per time bin (band) and mean (line); grey: the segments.",
                                        rec.sample_count(), estimation::report_number(ov.t1 - ov.t0, 3));
    const SensorInfo& info = rec.header.info;
    if (has_instrument(info, model::Instrument::kAccelerometer))
      s.add(overview_plot(ov, rec, 0, 3, 1.0, "accelerometer, raw", "specific force [m/s²]", {"ax", "ay", "az"}), cap);
    if (has_instrument(info, model::Instrument::kGyroscope))
      s.add(overview_plot(ov, rec, 3, 3, physics::kRadToDeg, "gyroscope, raw", "rate [deg/s]", {"gx", "gy", "gz"}), cap);
    if (info.has_accel != info.has_gyro) s.add_text("The recording holds " + instruments_text(info) + ".");
    if (temperature_recorded)
      s.add(overview_plot(ov, rec, kTemperatureChannel, 1, 1.0, "sensor temperature", "temperature [°C]",
                          {"temperature"}),
            cap);
    else
      s.add_text("No temperature was recorded.");
  } catch (const std::exception& e) {
    s.add_text(std::string("The samples could not be read for the overview: ") + e.what(),
               estimation::Emphasis::kWarning);
  }
  return s;
}

}  // namespace stend::reporting::detail
