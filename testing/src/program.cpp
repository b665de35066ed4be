#include "stend/testing/program.hpp"

#include "stend/testing/paths.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <regex>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

extern char** environ;

namespace stend::testing {

namespace {

// This process's environment with `env` added, as NAME=value strings.
std::vector<std::string> environment_with(const Environment& env) {
  std::vector<std::string> out;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    if (env.count(entry.substr(0, entry.find('='))) == 0) out.push_back(entry);
  }
  for (const auto& [name, value] : env) out.push_back(name + "=" + value);
  return out;
}

int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; }

}  // namespace

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

namespace {

// Whether process `pid` ended within `timeout_s` (reaped when it did).
bool ended_within(pid_t pid, double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// SIGINT to the process group of `pid` (the command and what it started); once `pid` has ended, or
// after 5 s, SIGKILL to what is left of the group (a shell's background children ignore SIGINT).
void stop_group(pid_t pid) {
  ::kill(-pid, SIGINT);
  const bool ended = ended_within(pid, 5.0);
  ::kill(-pid, SIGKILL);
  int status = 0;
  if (!ended) ::waitpid(pid, &status, 0);
}

}  // namespace

StartedCommand::StartedCommand(const std::string& command, const Environment& env) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::system_error(errno, std::generic_category(), "pipe");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  std::vector<std::string> envs = environment_with(env);
  std::vector<char*> envp;
  for (auto& e : envs) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::string sh = "sh", dash_c = "-c", line = command;
  std::array<char*, 4> argv = {sh.data(), dash_c.data(), line.data(), nullptr};
  // Its own process group, so that an abandoned command is stopped whole (~StartedCommand).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  const int rc = ::posix_spawn(&pid_, "/bin/sh", &actions, &attributes, argv.data(), envp.data());
  posix_spawnattr_destroy(&attributes);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    pid_ = -1;
    throw std::system_error(rc, std::generic_category(), "cannot start /bin/sh -c " + command);
  }
  out_ = ::fdopen(fds[0], "r");
}

StartedCommand::StartedCommand(StartedCommand&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)), out_(std::exchange(other.out_, nullptr)) {}

// A command nobody finished (a test that failed before it stopped its server) is interrupted, then
// killed, with everything it started: a failed assertion never hangs the test on a server left running.
StartedCommand::~StartedCommand() {
  if (pid_ > 0) stop_group(pid_);
  if (out_ != nullptr) std::fclose(out_);
}

std::string StartedCommand::wait_for(const std::string& pattern) {
  const std::regex re(pattern);
  std::array<char, 4096> buf{};
  while (out_ != nullptr && std::fgets(buf.data(), static_cast<int>(buf.size()), out_) != nullptr) {
    const std::string line = buf.data();
    std::smatch m;
    if (std::regex_search(line, m, re)) return m.size() > 1 ? m[1].str() : m[0].str();
  }
  return "";
}

void StartedCommand::interrupt() {
  if (pid_ > 0) ::kill(pid_, SIGINT);
}

ProgramOutput StartedCommand::finish() {
  ProgramOutput out;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while (out_ != nullptr && (n = std::fread(buf.data(), 1, buf.size(), out_)) > 0) out.text.append(buf.data(), n);
  if (out_ != nullptr) std::fclose(std::exchange(out_, nullptr));
  int status = 0;
  if (pid_ > 0 && ::waitpid(std::exchange(pid_, -1), &status, 0) > 0) out.code = exit_code(status);
  return out;
}

ProgramOutput run_command(const std::string& command, const Environment& env) {
  return StartedCommand(command, env).finish();
}

ProgramOutput run_stend(const std::string& args, const Environment& env) {
  return run_command(shell_quote(stend_program().string()) + " " + args, env);
}

StartedCommand start_stend(const std::string& args, const Environment& env) {
  return StartedCommand("exec " + shell_quote(stend_program().string()) + " " + args, env);
}

}  // namespace stend::testing
