// Machine-readable output of the `stend` program (--json): see commands.hpp.
#include "commands.hpp"

#include <cstdio>
#include <iostream>

namespace stend::cli {

namespace {
bool g_json = false;   // one process runs one command: set by that command's --json flag
bool g_quiet = false;  // set_quiet: a caller that reads the results, not the lines (python/)

// Where quiet lines go: nowhere.
std::FILE* discarded() {
  static std::FILE* sink = std::fopen("/dev/null", "w");
  return sink;
}
std::ostream& discarded_stream() {
  static std::ostream sink(nullptr);  // no buffer: every write is dropped
  return sink;
}
}  // namespace

void set_quiet(bool quiet) { g_quiet = quiet; }

void add_json_flag(CLI::App* sub, const std::string& what) {
  sub->add_flag("--json", g_json,
                "Print " + what + " as one JSON document on stdout (schema in docs/schemas/); the human-readable "
                "lines go to stderr");
}

bool json_output() { return g_json; }

std::FILE* human() {
  if (g_quiet && discarded() != nullptr) return discarded();
  return g_json ? stderr : stdout;
}

std::ostream& human_stream() {
  if (g_quiet) return discarded_stream();
  return g_json ? std::cerr : std::cout;
}

RunFolderLock lock_run(const std::filesystem::path& run_dir) {
  return RunFolderLock(run_dir, [&run_dir] {
    std::fprintf(stderr, "waiting: another stend command is writing into %s; this one goes on when it ends\n",
                 run_dir.string().c_str());
    std::fflush(stderr);
  });
}

void print_json(const nlohmann::json& doc) {
  if (!g_json) return;
  std::cout << doc.dump(2) << "\n";
  std::cout.flush();
}

}  // namespace stend::cli
