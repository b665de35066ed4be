// `stend report` — placeholder until issue 6 lands; it is registered so the CLI shape is fixed.
#include "commands.hpp"

#include <cstdio>

namespace stend::cli {

void add_report_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("report", "(not yet available)");
  sub->allow_extras();
  out.push_back({sub, [] {
                   std::fputs("stend report: not yet available in this build\n", stderr);
                   return 1;
                 }});
}

std::filesystem::path write_run_report(const std::filesystem::path&) { return {}; }

}  // namespace stend::cli
