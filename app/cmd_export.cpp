// `stend export RUN --to kalibr|matlab|imutk|px4|json|csv [-o FILE]` — a run's results in another
// tool's format, or (csv) the recording as a CSV run folder (see reporting/include/stend/reporting/exports.hpp and docs/reports.md).
#include "commands.hpp"

#include "stend/reporting/exports.hpp"

#include <fmt/format.h>

namespace stend::cli {

void add_export_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("export", "Export a run's results: Kalibr imu.yaml, MATLAB .mat (accelparams / "
                                           "gyroparams), IMU-TK calib files, PX4 thermal parameters, results JSON; "
                                           "or the recording itself as a CSV run folder");
  static std::string run, format, output;
  static stend::reporting::ExportOptions opt;
  sub->add_option("run", run, "Run folder")->required();
  sub->add_option("--to", format, "kalibr | matlab | imutk | px4 | json | csv")
      ->required()
      ->check(CLI::IsMember(stend::reporting::export_formats()));
  sub->add_option("-o,--output", output, "Output file (imutk: path prefix for _acc.calib / _gyro.calib; csv: a new "
                                         "folder); default RUN/export/");
  sub->add_option("--rostopic", opt.rostopic, "Kalibr: the IMU's ROS topic (default /imu0)");
  sub->add_option("--px4-id", opt.px4_device_id, "PX4: the sensor's device id for TC_A0_ID / CAL_ACC0_ID … (default 0)")
      ->check(at_least(0));
  sub->add_option("--from", opt.from,
                  "Calibration source: auto (Ceres when it is a full 3-axis calibration, else fit.json, then "
                  "temp_poly.json) | ceres | batch_lsq | temp_poly")
      ->check(CLI::IsMember({"auto", "ceres", "batch_lsq", "temp_poly"}));
  sub->add_option("--px4-instance", opt.px4_instance, "PX4: calibration slot n of TC_An / TC_Gn (default 0)")
      ->check(within(0, 3));
  sub->add_flag("--accept-damaged", opt.accept_damaged,
                "csv: copy the readable part of a damaged run (a truncated file, rows missing against run.json) "
                "instead of refusing it");
  add_json_flag(sub, "the files written");
  out.push_back({sub, [] {
                   const auto r = stend::reporting::export_run(run, format, output, opt);
                   nlohmann::json files = nlohmann::json::array();
                   for (const auto& f : r.files) {
                     fmt::print(human(), "wrote {}\n", f.string());
                     files.push_back(f.string());
                   }
                   for (const auto& n : r.notes) fmt::print(human(), "note: {}\n", n);
                   for (const auto& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
                   // docs/schemas/export.schema.json
                   print_json({{"files", files}, {"notes", r.notes}, {"warnings", r.warnings}});
                   return ExitCode::kOk;
                 }});
}

}  // namespace stend::cli
