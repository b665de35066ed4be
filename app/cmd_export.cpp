// `stend export RUN --to kalibr|matlab|imutk|px4|json|csv [-o FILE]` — a run's results in another
// tool's format, or (csv) the recording as a CSV run folder (see reporting/include/stend/reporting/exports.hpp and docs/reports.md).
// `stend export (RUN | --procedure FP) --db LOCATION --to json -o FILE` — the same results JSON read
// from the results store instead of the folder (docs/lab-scale.md): the store only holds the
// parameters and documents, so the other formats, which need the estimators' files, read folders.
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/estimators/builtin.hpp"
#include "stend/recording/files.hpp"
#include "stend/reporting/exports.hpp"
#include "stend/reporting/results_store.hpp"

#include <fmt/format.h>

namespace stend::cli {

namespace {

namespace rp = stend::reporting;

// The schema of a campaign exported from the store: stend.results/1 documents of every run.
constexpr const char* kResultsSetSchema = "stend.results_set/1";

rp::ExportResult export_from_store(const std::string& run, const std::string& procedure, const std::string& db,
                                   const std::string& format, const std::string& output) {
  if (format != "json")
    throw InputError(fmt::format("stend export --db: only --to json reads the results store (--to {} needs the run "
                                 "folder's results files: give the folder without --db)",
                                 format));
  if (output.empty()) throw InputError("stend export --db: give the file to write with -o FILE");
  if (run.empty() == procedure.empty())
    throw InputError("stend export --db: give either one run (its folder or name) or --procedure FINGERPRINT");
  const rp::ResultsStore store(rp::results_store_location(db));
  nlohmann::json doc;
  std::size_t runs = 1;
  if (!run.empty()) {
    const rp::RunResults r = store.find_run(run);
    if (r.dir.empty()) throw InputError(fmt::format("stend export: no run '{}' in {}", run, store.where()));
    doc = rp::to_json(r);
  } else {
    const auto found = store.with_fingerprint(procedure);
    if (found.empty())
      throw InputError(fmt::format("stend export: no run in {} has procedure fingerprint {}", store.where(), procedure));
    doc = {{"schema", kResultsSetSchema}, {"store", store.where()}, {"procedure", procedure},
           {"runs", nlohmann::json::array()}};
    for (const auto& r : found) doc["runs"].push_back(rp::to_json(r));
    runs = found.size();
  }
  write_file_atomic(output, doc.dump(2) + '\n');
  rp::ExportResult result;
  result.files.push_back(output);
  result.notes.push_back(fmt::format("{} run(s) read from the results store {}", runs, store.where()));
  return result;
}

}  // namespace

Outcome run_export(const ExportArgs& a) {
  if (a.db.empty() && !a.procedure.empty())
    throw InputError("stend export --procedure: give the results store with --db LOCATION");
  if (a.db.empty() && a.run.empty()) throw InputError("stend export: give the run folder");
  const RunFolderLock lock = lock_run(a.db.empty() ? a.run : std::string());  // one command at a time on a run
  rp::ExportOptions options = a.options;
  for (const auto& text : a.assumptions)
    for (auto& v : estimation::parse_assumptions(text)) options.assumed.push_back(std::move(v));
  const auto r = a.db.empty() ? rp::export_run(a.run, a.format, a.output, estimators::builtin(), options)
                              : export_from_store(a.run, a.procedure, a.db, a.format, a.output);
  nlohmann::json files = nlohmann::json::array();
  for (const auto& f : r.files) {
    fmt::print(human(), "wrote {}\n", f.string());
    files.push_back(f.string());
  }
  for (const auto& n : r.notes) fmt::print(human(), "note: {}\n", n);
  for (const auto& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
  // docs/schemas/export.schema.json
  return {ExitCode::kOk, {{"files", files}, {"notes", r.notes}, {"warnings", r.warnings}}};
}

void add_export_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("export", "Export a run's results: Kalibr imu.yaml, MATLAB .mat (accelparams / "
                                           "gyroparams), IMU-TK calib files, PX4 thermal parameters, results JSON; "
                                           "or the recording itself as a CSV run folder");
  static ExportArgs a;
  auto& opt = a.options;
  sub->add_option("run", a.run, "Run folder (with --db: a run folder or name in the store)");
  sub->add_option("--to", a.format, "kalibr | matlab | imutk | px4 | json | csv")
      ->required()
      ->check(CLI::IsMember(stend::reporting::export_formats()));
  sub->add_option("-o,--output", a.output, "Output file (imutk: path prefix for _acc.calib / _gyro.calib; csv: a new "
                                         "folder); default RUN/export/");
  sub->add_option("--db", a.db, std::string(kDbOptionHelp) + "; given, --to json reads the results from the store");
  sub->add_option("--procedure", a.procedure, "With --db: every run of this procedure fingerprint (or a prefix of at "
                                            "least 8 hex digits) into one stend.results_set/1 file");
  sub->add_option("--rostopic", opt.rostopic, "Kalibr: the IMU's ROS topic (default /imu0)");
  sub->add_option("--px4-id", opt.px4_device_id, "PX4: the sensor's device id for TC_A0_ID / CAL_ACC0_ID … (default 0)")
      ->check(at_least(0));
  sub->add_option("--from", opt.from,
                  "Calibration source: auto (Ceres when it is a full 3-axis calibration, else fit.json, then "
                  "temp_poly.json) | ceres | batch_lsq | temp_poly (an estimator's name)")
      ->check(CLI::Validator(
          [](std::string& from) -> std::string {
            try {
              stend::reporting::calibration_source(stend::estimators::builtin(), from);
              return {};
            } catch (const InputError& e) {
              return e.what();
            }
          },
          "auto|ESTIMATOR"));
  sub->add_option("--px4-instance", opt.px4_instance, "PX4: calibration slot n of TC_An / TC_Gn (default 0)")
      ->check(within(0, 3));
  sub->add_flag("--accept-damaged", opt.accept_damaged,
                "csv: copy the readable part of a damaged run (a truncated file, rows missing against run.json) "
                "instead of refusing it");
  sub->add_option("--assume", a.assumptions, kAssumeHelp);
  add_json_flag(sub, "the files written");
  out.push_back({sub, [] {
                   const Outcome o = run_export(a);
                   print_json(o.doc);
                   return o.code;
                 }});
}

}  // namespace stend::cli
