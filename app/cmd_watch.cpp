// `stend watch RUN` — the live view of a run folder, in progress or finished (re-read once a
// second), until Ctrl-C. Also LiveRun, the live view `stend run --live` serves.
#include "commands.hpp"
#include "live_view.hpp"

#include "stend/core/experiment.hpp"
#include "stend/live/run_folder_feed.hpp"
#include "stend/core/plugin_host.hpp"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <thread>

namespace stend::cli {

namespace {

constexpr double kRefreshPeriod_s = 1.0;  // stend watch re-reads the run folder this often
constexpr double kFinalLinger_s = 2.5;    // stend run --live: serves the final state this long (> the page's poll)

std::atomic<bool> g_watch_stop{false};
extern "C" void on_watch_signal(int) { g_watch_stop.store(true); }

// The procedure of the run's experiment.yaml, read with the plugins on the search path; empty
// (no step count, no time left) when it cannot be read, said on stderr.
std::vector<Step> run_procedure(const std::filesystem::path& run) {
  try {
    PluginHost host;
    host.scan(PluginHost::default_search_path());
    return load_experiment((run / "experiment.yaml").string(), host).procedure;
  } catch (const std::exception& e) {
    fmt::print(stderr, "watch: the run's procedure is not shown (no step count, no time left): {}\n", e.what());
    return {};
  }
}

ExitCode watch(const std::filesystem::path& run, const LiveArgs& args) {
  live::LiveState state(run.filename().string());
  live::RunFolderFeed feed(run, run_procedure(run));
  feed.refresh(state);  // a folder that is not a recording is refused before serving
  const live::LiveServer server(state, args.server);
  announce(server);
  std::signal(SIGINT, on_watch_signal);
  std::signal(SIGTERM, on_watch_signal);
  auto next = std::chrono::steady_clock::now();
  while (!g_watch_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (std::chrono::steady_clock::now() < next) continue;
    next += std::chrono::milliseconds(static_cast<int>(kRefreshPeriod_s * 1000));
    try {
      feed.refresh(state);
    } catch (const std::exception& e) {  // e.g. a file replaced while read: say so, try again
      fmt::print(stderr, "watch: {}: {}\n", run.string(), e.what());
    }
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  return ExitCode::kOk;
}

}  // namespace

void LiveArgs::add_to(CLI::App* sub, bool with_flag) {
  if (with_flag) sub->add_flag("--live", live, "Serve a live view of the run (read-only page; docs/live-view.md)");
  sub->add_option("--port", server.port, "Port of the live view (0: any free port)")->capture_default_str()->check(CLI::Range(0, 65535));
  sub->add_option("--bind", server.address,
                  "Address the live view listens on (127.0.0.1: this machine only)")
      ->capture_default_str();
}

void announce(const live::LiveServer& server) {
  fmt::print(stderr, "live view: {} (read-only{})\n", server.url(),
             live::charts_built_in() ? "" : "; charts not built in: scripts/vendor-web-deps.sh");
  std::fflush(stderr);
}

LiveRun::LiveRun(const LiveArgs& args, const std::string& run_name) {
  if (!args.live) return;
  state_ = std::make_unique<live::LiveState>(run_name);
  server_ = std::make_unique<live::LiveServer>(*state_, args.server);
  announce(*server_);
}

void LiveRun::update(const RunProgress& p) {
  if (state_) state_->update(p);
}

void LiveRun::finish(RunStatus status, const std::string& message) {
  if (!state_) return;
  state_->set_status(status, message);
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(kFinalLinger_s * 1000)));
  server_.reset();
}

void add_watch_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("watch", "Serve a live view of a run folder, in progress or finished, until Ctrl-C");
  static std::string run;
  static LiveArgs args;
  sub->add_option("run", run, "Run folder")->required();
  args.add_to(sub, false);
  out.push_back({sub, [] { return watch(run, args); }});
}

}  // namespace stend::cli
