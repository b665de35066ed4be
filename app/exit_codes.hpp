// The `stend` program's exit codes, written once; docs/errors.md lists them with what the user
// sees for each kind of bad input. Every command returns one of these; an exception that ends a
// command is mapped to one in one place (exit_code_of_current_exception).
#pragma once

#include <stdexcept>
#include <string>

namespace stend::cli {

enum class ExitCode : int {
  kOk = 0,
  kUsage = 1,         // the command line is wrong: unknown option, missing argument, value out of range
  kInvalidInput = 2,  // an experiment, model or data file or a run folder cannot be used as it is
  kFitFailed = 3,     // the analysis ran and failed (it says why, no numbers); validation targets not met
  kIoFailure = 4,     // a write, sync or rename failed; a device did not answer; a run failed on the bench
  kStopped = 130,     // SIGINT or SIGTERM stopped a run (closed as interrupted, everything recorded kept)
};

constexpr int to_int(ExitCode code) { return static_cast<int>(code); }

// Inside a catch block: prints the exception being handled to stderr ("error: …") and returns
// its exit code — kInvalidInput for bad input (InputError and the library errors about a value:
// YAML, JSON, invalid_argument, out_of_range, …), kIoFailure for the file system and devices
// (IoError, filesystem and stream errors, MODBUS / text-command / I2C / fixture link faults),
// kUsage for anything else (an error of the program itself, said as "internal error").
ExitCode exit_code_of_current_exception();

// The same mapping without printing: the exit code and the line the program prints for it
// (e.g. "error: …"), for callers that report it themselves (the Python module, python/).
struct Failure {
  ExitCode code = ExitCode::kUsage;
  std::string text;
};
Failure failure_of_current_exception();

// A command's refusal with its own exit code (the folder exists, nothing to do, …): its message is
// printed as is, without "error: ".
class Refusal : public std::runtime_error {
 public:
  Refusal(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

}  // namespace stend::cli
