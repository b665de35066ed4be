// The requested deviations of every channel: options, streaming pass, JSON, table
// (stend/allan/deviation_report.hpp).
#include <stend/allan/deviation_report.hpp>
#include <stend/errors.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <ostream>
#include <stdexcept>

namespace stend::allan {

const char* to_string(TauSpacing t) {
  switch (t) {
    case TauSpacing::kOctave: return "octave";
    case TauSpacing::kLog: return "log";
    case TauSpacing::kAll: return "all";
  }
  return "?";
}

bool DeviationRequest::IsValid(std::string* why) const {
  for (std::size_t i = 0; i < kinds.size(); ++i) {
    if (std::find(kinds.begin(), kinds.begin() + static_cast<std::ptrdiff_t>(i), kinds[i]) !=
        kinds.begin() + static_cast<std::ptrdiff_t>(i)) {
      if (why) *why = fmt::format("'{}' is requested twice", to_string(kinds[i]));
      return false;
    }
  }
  return true;
}

bool is_deviation_key(const std::string& key) { return key == "deviations" || key == "tau"; }

namespace {

[[noreturn]] void fail(const std::string& file, const YAML::Node& at, const std::string& what) {
  throw InputError(fmt::format("{}: allan option {}", yaml_location(file, at), what));
}

DeviationKind kind_named(const std::string& file, const YAML::Node& v) {
  const std::string name = v.IsScalar() ? v.Scalar() : std::string();
  for (DeviationKind k : kAllDeviationKinds) {
    if (name == to_string(k)) return k;
  }
  std::string known;
  for (DeviationKind k : kAllDeviationKinds) known += fmt::format("{}{}", known.empty() ? "" : ", ", to_string(k));
  fail(file, v, fmt::format("'deviations': unknown kind '{}' (known: {})", name, known));
}

}  // namespace

DeviationRequest deviations_from_yaml(const YAML::Node& allan, const std::string& file) {
  DeviationRequest r;
  if (!allan || !allan.IsMap()) return r;
  if (const YAML::Node list = allan["deviations"]) {
    if (!list.IsSequence()) fail(file, list, "'deviations': expected a list such as [oadev, mdev, hdev]");
    for (const auto& v : list) {
      r.kinds.push_back(kind_named(file, v));
      std::string why;
      if (!r.IsValid(&why)) fail(file, v, "'deviations': " + why);
    }
  }
  if (const YAML::Node tau = allan["tau"]) {
    const std::string s = tau.IsScalar() ? tau.Scalar() : std::string();
    if (s == "octave") r.tau = TauSpacing::kOctave;
    else if (s == "log") r.tau = TauSpacing::kLog;
    else if (s == "all") r.tau = TauSpacing::kAll;
    else fail(file, tau, fmt::format("'tau': expected octave, log or all, got '{}'", s));
  }
  return r;
}

std::vector<std::uint64_t> deviation_factors(TauSpacing spacing, std::uint64_t samples, std::uint64_t max_m) {
  // N rate samples are N + 1 phase points; no kind reaches beyond (N + 1) / 2 (TOTDEV's stop ratio).
  const std::uint64_t cap = std::min(max_m, (samples + 1) / stop_ratio(DeviationKind::kTotdev));
  if (cap == 0) return {};
  switch (spacing) {
    case TauSpacing::kAll: return all_factors(cap);
    case TauSpacing::kLog: return log_factors(cap, kLogFactorsPerDecade);
    case TauSpacing::kOctave: break;
  }
  std::vector<std::uint64_t> out;
  for (std::uint64_t m = 1; m <= cap; m *= 2) out.push_back(m);
  return out;
}

namespace {

// The stream for `samples` rate samples at rate_hz, or null when no factor fits.
std::unique_ptr<DeviationStream> make_stream(const DeviationRequest& request, std::uint64_t samples,
                                             double rate_hz, const AllanOptions& options) {
  auto factors = deviation_factors(request.tau, samples, options.max_m);
  if (factors.empty()) return nullptr;
  DeviationOptions o;
  o.max_m = factors.back();
  o.factors = std::move(factors);
  o.tau0_s = 1.0 / rate_hz;
  o.confidence = options.confidence;
  return std::make_unique<DeviationStream>(std::move(o));
}

ChannelDeviations collect(DeviationStream* stream, const DeviationRequest& request, std::uint64_t samples,
                          double rate_hz, const ChannelInfo& channel, const AllanOptions& options) {
  ChannelDeviations out;
  out.channel = channel;
  if (out.channel.unit.empty()) out.channel.unit = units_for(channel.instrument).signal;
  out.rate_hz = rate_hz;
  out.samples = samples;
  out.confidence = options.confidence;
  for (DeviationKind k : request.kinds) {
    out.kinds.emplace_back(k, stream ? stream->result(k) : std::vector<DeviationPoint>{});
  }
  return out;
}

}  // namespace

ChannelDeviations channel_deviations(const double* y, std::size_t n, double rate_hz, const ChannelInfo& channel,
                                     const DeviationRequest& request, const AllanOptions& options) {
  auto stream = make_stream(request, n, rate_hz, options);
  if (stream) stream->add_rate(y, n);
  return collect(stream.get(), request, n, rate_hz, channel, options);
}

ChannelDeviations phase_deviations(const double* x, std::size_t n, double rate_hz, const ChannelInfo& channel,
                                   const DeviationRequest& request, const AllanOptions& options) {
  const std::size_t samples = n > 0 ? n - 1 : 0;
  auto stream = make_stream(request, samples, rate_hz, options);
  if (stream) stream->add_phase(x, n);
  return collect(stream.get(), request, samples, rate_hz, channel, options);
}

std::vector<ChannelDeviations> recording_deviations(const Recording& recording, const AllanReport& report,
                                                    const DeviationRequest& request,
                                                    const AllanOptions& options) {
  const std::vector<Channel> columns = noise_channels(recording.header.info);  // as the report's channels
  std::vector<ChannelDeviations> out;
  if (request.empty()) return out;
  const SampleSource& src = recording.sample_source();
  const std::uint64_t first = lower_bound_time(src, report.t_begin_s);
  std::vector<double> buf(kDefaultChunkSamples);
  for (std::size_t ch = 0; ch < report.channels.size() && ch < columns.size(); ++ch) {
    auto stream = make_stream(request, report.samples, report.rate_hz, options);
    for (std::uint64_t i = first; stream && i < first + report.samples;) {
      const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), first + report.samples - i));
      src.read_column(columns[ch], i, take, buf.data());
      stream->add_rate(buf.data(), take);
      i += take;
    }
    out.push_back(collect(stream.get(), request, report.samples, report.rate_hz,
                          report.channels[ch].curve.channel, options));
  }
  return out;
}

void add_deviations_json(nlohmann::json& doc, const std::vector<ChannelDeviations>& channels,
                         TauSpacing spacing) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json all = nlohmann::json::array();
  for (const auto& c : channels) {
    nlohmann::json kinds = nlohmann::json::object();
    for (const auto& [kind, points] : c.kinds) {
      nlohmann::json rows = nlohmann::json::array();
      for (const auto& p : points) {
        rows.push_back({{"tau_s", p.tau_s}, {"m", p.m}, {"terms", p.terms}, {"value", number(p.dev)},
                        {"edf", number(p.edf)}, {"lo", number(p.lo)}, {"hi", number(p.hi)},
                        {"alpha", p.alpha}});
      }
      kinds[to_string(kind)] = std::move(rows);
    }
    all.push_back({{"channel", c.channel.name}, {"unit", c.channel.unit}, {"rate_hz", c.rate_hz},
                   {"samples", c.samples}, {"confidence", c.confidence},
                   {"tau_spacing", to_string(spacing)}, {"kinds", std::move(kinds)}});
  }
  doc["deviations"] = std::move(all);
}

void write_deviation_table(std::ostream& os, const std::vector<ChannelDeviations>& channels) {
  for (const auto& c : channels) {
    if (c.kinds.empty()) continue;
    os << fmt::format("deviations of {} [{}; tdev {}*s], {} samples at {:.6g} Hz (alpha, EDF and "
                      "{:.1f} % intervals per point in the JSON)\n",
                      c.channel.name, c.channel.unit, c.channel.unit, c.samples, c.rate_hz, 100.0 * c.confidence);
    // Rows: the τ of the kind with the most points (every kind's factors are a prefix of them).
    const auto longest = std::max_element(c.kinds.begin(), c.kinds.end(), [](const auto& a, const auto& b) {
      return a.second.size() < b.second.size();
    });
    os << fmt::format("  {:>12}", "tau [s]");
    for (const auto& k : c.kinds) os << fmt::format(" {:>11}", to_string(k.first));
    os << "\n";
    for (std::size_t i = 0; i < longest->second.size(); ++i) {
      const std::uint64_t m = longest->second[i].m;
      os << fmt::format("  {:>12.6g}", longest->second[i].tau_s);
      for (const auto& k : c.kinds) {
        const auto it = std::find_if(k.second.begin(), k.second.end(), [m](const DeviationPoint& p) { return p.m == m; });
        os << (it == k.second.end() ? fmt::format(" {:>11}", "-") : fmt::format(" {:>11.5g}", it->dev));
      }
      os << "\n";
    }
  }
}

}  // namespace stend::allan
