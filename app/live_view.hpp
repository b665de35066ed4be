// The live view from the command line: `stend run … --live [--port N] [--bind ADDR]` serves the
// run in this process, `stend watch RUN` a run folder (cmd_watch.cpp). docs/live-view.md.
#pragma once

#include "stend/live/live_state.hpp"
#include "stend/live/server.hpp"

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

namespace stend::cli {

// The options both commands take.
struct LiveArgs {
  bool live = false;  // stend run: serve the live view
  live::LiveServerOptions server;
  // Adds --port and --bind (and --live when `with_flag`) to `sub`.
  void add_to(CLI::App* sub, bool with_flag);
};

// A live view of the run in this process: update() from RunOptions::on_progress; finish() gives
// the final status and keeps serving a moment so that open pages see it.
class LiveRun {
 public:
  LiveRun(const LiveArgs& args, const std::string& run_name);  // serves nothing unless args.live
  void update(const RunProgress& p);
  void finish(RunStatus status, const std::string& message);

 private:
  std::unique_ptr<live::LiveState> state_;
  std::unique_ptr<live::LiveServer> server_;
};

// Prints where the view is served ("live view: http://127.0.0.1:8765/ (read-only)") on stderr.
void announce(const live::LiveServer& server);

}  // namespace stend::cli
