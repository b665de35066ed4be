// The `stend` program's subcommands. main.cpp owns run/validate/info/plugins/fit; every other
// subcommand lives in its own cmd_<name>.cpp and registers itself through add_<name>_command.
#pragma once

#include "stend/recording.hpp"

#include <CLI/CLI.hpp>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace stend::cli {

// A registered subcommand: `run` is called after parsing when `sub` was given on the command
// line; its return value is the process exit code (0 ok, 1 error, 2 bad input, 3 fit failed).
struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> run;
};

// ---- shared analysis helpers (app/fit.cpp) -----------------------------------------------------

// A recording from a run folder, or a dataset file through its importer:
//   format = run | imucal | mpu6050_multipos | mat | imutk ("ACC_FILE,GYRO_FILE") | auto.
stend::Recording open_recording(const std::string& input, std::string format);

// Fits `model_file` to `rec` with the estimator named `estimator` ("auto": the one the model file
// is written for, through the estimator registry), prints the report to stdout and writes the
// results JSON (+ a .txt copy) to `json_out`, or to out_dir/<the estimator's results file> when
// empty. Returns false when the fit failed (it says why, with no numbers).
// Writes the results document to `json` and the printed text beside it (.txt); with no path (the
// input is a dataset file, not a run folder, and no --json was given) writes nothing and says so.
void write_results(std::filesystem::path json, const std::string& document, const std::string& text);

bool fit_recording(const stend::Recording& rec, const std::string& model_file, const std::filesystem::path& out_dir,
                   const std::string& json_out, const std::string& estimator = "auto");

// ---- subcommands in their own files ------------------------------------------------------------
void add_gap_command(CLI::App& app, std::vector<Command>& out);      // cmd_gap.cpp
void add_report_command(CLI::App& app, std::vector<Command>& out);   // cmd_report.cpp
void add_compare_command(CLI::App& app, std::vector<Command>& out);  // cmd_compare.cpp
void add_export_command(CLI::App& app, std::vector<Command>& out);   // cmd_export.cpp
void add_emulate_command(CLI::App& app, std::vector<Command>& out);  // cmd_emulate.cpp
void add_apply_command(CLI::App& app, std::vector<Command>& out);    // cmd_apply.cpp

// Builds RUN/report.html from what the run folder holds (called at the end of `stend run`).
// Returns the report path, or an empty path when no report could be written (says why on stderr).
std::filesystem::path write_run_report(const std::filesystem::path& run_dir);

}  // namespace stend::cli
