// Exports of a run's results (see exports.hpp): the format table and the dispatch; each format in
// export_<format>.cpp, what they write from in export_sources.cpp.
#include "stend/reporting/exports.hpp"

#include "export_formats.hpp"
#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "stend/recording/recording.hpp"
#include "stend/reporting/results.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <map>

namespace stend::reporting {

namespace fs = std::filesystem;

bool ExportOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (rostopic.empty()) return fail("rostopic: give the IMU's ROS topic, e.g. /imu0");
  if (px4_instance < 0 || px4_instance > 3) return fail("px4_instance must be 0..3");
  if (px4_device_id < 0) return fail("px4_device_id must be >= 0");
  if (from.empty()) return fail("from: name the calibration source (auto or an estimator)");
  return true;
}

const std::vector<std::string>& export_formats() {
  static const std::vector<std::string> f = {"kalibr", "matlab", "imutk", "px4", "json", "csv"};
  return f;
}

ExportResult export_run(const fs::path& run_dir, const std::string& format, fs::path out,
                        const estimation::Registry& registry, const ExportOptions& options) {
  if (std::string why; !options.IsValid(&why)) throw InputError("stend export: " + why);
  if (format == "csv") {  // the recording itself, as a CSV run folder
    if (out.empty()) out = run_dir / "export" / "csv";
    const Recording rec = Recording::open(run_dir, SampleLoading::kStream);
    if (!options.accept_damaged) require_whole(rec);
    write_recording(rec, out, RecordingWriterOptions{RecordingFormat::kCsv});
    ExportResult r;
    for (const char* f : {"run.json", "experiment.yaml", "imu.csv", "truth.csv", "segments.csv", "events.csv"})
      r.files.push_back(out / f);
    if (!rec.damage.empty()) r.warnings.push_back(fmt::format("{} of {} samples exported: {}", rec.sample_count(), rec.written_samples, rec.damage));
    return r;
  }
  require_whole_results(run_dir, registry);
  RunResults identity = load_run_results(run_dir, registry);
  const fs::path run = identity.dir;
  if (out.empty()) {
    fs::create_directories(run / "export");
    const std::map<std::string, std::string> names = {{"kalibr", "imu.yaml"},        {"matlab", "stend_params.mat"},
                                                      {"imutk", "imutk"},            {"px4", "px4.params"},
                                                      {"json", "results.json"}};
    const auto it = names.find(format);
    if (it == names.end()) throw InputError("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
    out = run / "export" / it->second;
  } else if (out.has_parent_path()) {
    fs::create_directories(out.parent_path());
  }
  if (format == "json") {
    write_file_atomic(out, to_json(identity).dump(2) + '\n');
    ExportResult r;
    r.files.push_back(out);
    return r;
  }
  const detail::RunData data = detail::read_run(std::move(identity), registry);
  if (format == "kalibr") return detail::export_kalibr(data, out, options);
  if (format == "imutk") return detail::export_imutk(data, out, options);
  if (format == "px4") return detail::export_px4(data, out, options);
  if (format == "matlab") return detail::export_matlab(data, out, options);
  throw InputError("unknown export format '" + format + "' (kalibr|matlab|imutk|px4|json)");
}

}  // namespace stend::reporting
