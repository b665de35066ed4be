// `stend info RUN`: what a recording holds — header, extents, segments, events — without a scan of
// the samples (docs/schemas/info.schema.json).
#include "commands.hpp"

#include "stend/recording/instruments.hpp"
#include "stend/recording/recording.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace stend::cli {

namespace {

using nlohmann::json;

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// docs/schemas/info.schema.json
json info_json(const stend::Recording& rec, std::uint64_t n, const stend::ImuSample& first, const stend::ImuSample& last) {
  const auto& h = rec.header;
  json j = {{"recording", rec.dir.string()},
            {"format", stend::to_string(rec.format)},
            {"experiment", h.experiment_name},
            {"stend_version", h.stend_version},
            {"status", stend::to_string(h.status)},
            {"complete", rec.complete()},
            {"sensor", {{"vendor", h.identity.vendor},
                        {"model", h.identity.model},
                        {"serial", h.identity.serial},
                        {"who_am_i", h.identity.who_am_i},
                        {"output_rate_hz", h.info.output_rate_hz},
                        {"has_accel", h.info.has_accel},
                        {"has_gyro", h.info.has_gyro},
                        {"has_temperature", h.info.has_temperature}}},
            {"gravity_mps2", h.gravity_mps2},
            {"clock", h.clock},
            {"seed", h.seed},
            {"samples", n},
            {"t_first_s", n > 0 ? finite_or_null(first.t_s) : json(nullptr)},
            {"t_last_s", n > 0 ? finite_or_null(last.t_s) : json(nullptr)},
            {"gaps", rec.gap_count >= 0 ? json(rec.gap_count) : json(nullptr)},
            {"truth_rows", rec.truth_rows},
            {"damage", rec.damage}};
  j["segments"] = json::array();
  for (const auto& s : rec.segments)
    j["segments"].push_back({{"id", s.id},
                             {"kind", stend::to_string(s.kind)},
                             {"t_start_s", finite_or_null(s.t_start_s)},
                             {"t_end_s", finite_or_null(s.t_end_s)},
                             {"settled", s.settled},
                             {"complete", s.complete},
                             {"label", s.label},
                             {"targets", s.targets}});
  j["events"] = json::array();
  for (const auto& e : rec.events)
    j["events"].push_back({{"t_s", finite_or_null(e.t_s)}, {"level", e.level}, {"source", e.source}, {"message", e.message}});
  return j;
}

}  // namespace

nlohmann::json recording_summary(const Recording& rec) {
  const auto& src = rec.sample_source();
  const std::uint64_t n = src.size();
  ImuSample first, last;
  if (n > 0) {
    src.read(0, 1, &first);
    src.read(n - 1, 1, &last);
  }
  return info_json(rec, n, first, last);
}

Outcome run_info(const std::string& dir) {
  // Header, extents and the first and last samples only: no scan of the samples.
  const stend::Recording rec =
      stend::Recording::open(dir, stend::SampleLoading::kStream, stend::TruthLoading::kSkip);
  const auto& h = rec.header;
  std::FILE* out = human();
  fmt::print(out, "recording:  {} ({})\nexperiment: {} (stend {})\nstatus:     {}{}\n", rec.dir.string(),
             stend::to_string(rec.format), h.experiment_name, h.stend_version, stend::to_string(h.status),
             rec.complete() ? "" : " (incomplete)");
  fmt::print(out, "sensor:     {} {} serial '{}' WHO_AM_I {} at {} Hz\n", h.identity.vendor, h.identity.model,
             h.identity.serial, h.identity.who_am_i, h.info.output_rate_hz);
  fmt::print(out, "measures:   {}\n", stend::instruments_text(h.info));
  fmt::print(out, "gravity:    {:.6f} m/s^2; clock {}; seed {}\n", h.gravity_mps2, h.clock, h.seed);
  const auto& src = rec.sample_source();
  const std::uint64_t n = src.size();
  fmt::print(out, "data:       {} samples", n);
  stend::ImuSample first, last;
  if (n > 0) {
    src.read(0, 1, &first);
    src.read(n - 1, 1, &last);
    fmt::print(out, " from {:.3f} s to {:.3f} s", first.t_s, last.t_s);
  }
  if (rec.gap_count >= 0) fmt::print(out, ", {} gaps", rec.gap_count);
  fmt::print(out, ", {} truth rows, {} segments, {} events\n", rec.truth_rows, rec.segments.size(), rec.events.size());
  if (!rec.damage.empty())
    fmt::print(out, "damaged:    {} of {} samples are readable: {}\n", n, rec.written_samples, rec.damage);
  for (const auto& s : rec.segments)
    fmt::print(out, "  #{:<3} {:<15} {:>7.2f}–{:<8.2f} s {}{}{}  {}\n", s.id, stend::to_string(s.kind), s.t_start_s, s.t_end_s,
               s.settled ? "" : "[unsettled] ", s.complete ? "" : "[incomplete] ", s.label, s.targets);
  for (const auto& e : rec.events) fmt::print(out, "  event {:.3f} s {} {}: {}\n", e.t_s, e.level, e.source, e.message);
  return {ExitCode::kOk, recording_summary(rec)};
}


}  // namespace stend::cli
