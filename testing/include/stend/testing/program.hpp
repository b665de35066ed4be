// Commands run from a test, above all this build tree's `stend` program: run to the end (exit code
// and everything printed), or started in the background and read line by line while it runs.
#pragma once

#include <sys/types.h>

#include <cstdio>
#include <map>
#include <string>

namespace stend::testing {

// Variables added to (or replacing those of) this process's environment for one command.
using Environment = std::map<std::string, std::string>;

struct ProgramOutput {
  int code = -1;     // exit status; -1 when the command could not start or was ended by a signal
  std::string text;  // stdout and stderr, interleaved as written
};

// Quotes `s` as one /bin/sh word.
std::string shell_quote(const std::string& s);

// Runs a /bin/sh command line to its end.
ProgramOutput run_command(const std::string& command, const Environment& env = {});

// Runs this build tree's stend program with `args` (a /bin/sh word list): run_stend("validate " + file).
ProgramOutput run_stend(const std::string& args, const Environment& env = {});

// A /bin/sh command line started in the background, stdout and stderr on one pipe. The destructor
// closes the pipe and waits for the command to end.
class StartedCommand {
 public:
  explicit StartedCommand(const std::string& command, const Environment& env = {});
  ~StartedCommand();
  StartedCommand(StartedCommand&& other) noexcept;
  StartedCommand(const StartedCommand&) = delete;
  StartedCommand& operator=(const StartedCommand&) = delete;
  StartedCommand& operator=(StartedCommand&&) = delete;

  // Reads output lines until one matches the regular expression `pattern`; returns its first group
  // (the whole match when it has none), or "" when the output ends first.
  std::string wait_for(const std::string& pattern);

  // Reads the rest of the output and waits for the end: the exit status and what was not yet read.
  ProgramOutput finish();

  // Sends SIGINT (as Ctrl-C would) to the command's process: the shell, or the program itself when
  // the command line starts with `exec` (start_stend's does).
  void interrupt();

 private:
  pid_t pid_ = -1;
  std::FILE* out_ = nullptr;  // read end of the command's stdout+stderr
};

// This build tree's stend program started in the background: start_stend("emulate table --port 0").
// The shell execs it, so interrupt() reaches the program itself.
StartedCommand start_stend(const std::string& args, const Environment& env = {});

}  // namespace stend::testing
