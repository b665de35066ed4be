// Exceptions that end a command → the program's exit code, in one place (exit_codes.hpp).
#include "exit_codes.hpp"

#include "stend/errors.hpp"
#include "stend/core/experiment.hpp"
#include "stend/sdk.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <ios>
#include <stdexcept>
#include <system_error>

namespace stend::cli {

namespace {

Failure say(ExitCode code, const char* prefix, const char* what) { return {code, std::string(prefix) + what}; }

}  // namespace

ExitCode exit_code_of_current_exception() {
  const Failure f = failure_of_current_exception();
  fmt::print(stderr, "{}\n", f.text);
  return f.code;
}

Failure failure_of_current_exception() {
  constexpr ExitCode kInput = ExitCode::kInvalidInput, kIo = ExitCode::kIoFailure;
  try {
    throw;
  } catch (const Refusal& e) {  // the command's own words and exit code
    return say(e.code(), "", e.what());
  } catch (const ExperimentError& e) {  // its text reads "FILE:LINE:COL: error: …" already
    return say(kInput, "", e.what());
  } catch (const InputError& e) {
    return say(kInput, "error: ", e.what());
  } catch (const IoError& e) {  // a failed write, a device or link that failed (FixtureLinkFault, transports)
    return say(kIo, "error: ", e.what());
  } catch (const std::system_error& e) {  // filesystem and stream failures
    return say(kIo, "error: ", e.what());
  } catch (const YAML::Exception& e) {
    return say(kInput, "error: ", e.what());
  } catch (const nlohmann::json::exception& e) {
    return say(kInput, "error: ", e.what());
  } catch (const std::runtime_error& e) {  // the libraries' "this input does not allow that"
    return say(kInput, "error: ", e.what());
  } catch (const std::invalid_argument& e) {
    return say(kInput, "error: ", e.what());
  } catch (const std::domain_error& e) {
    return say(kInput, "error: ", e.what());
  } catch (const std::out_of_range& e) {
    return say(kInput, "error: ", e.what());
  } catch (const std::exception& e) {
    return say(ExitCode::kUsage, "internal error: ", e.what());
  } catch (...) {
    return say(ExitCode::kUsage, "internal error: ", "unknown exception");
  }
}

}  // namespace stend::cli
