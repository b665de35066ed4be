// `stend compare` — placeholder until issue 6 lands; it is registered so the CLI shape is fixed.
#include "commands.hpp"

#include <cstdio>

namespace stend::cli {

void add_compare_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("compare", "(not yet available)");
  sub->allow_extras();
  out.push_back({sub, [] {
                   std::fputs("stend compare: not yet available in this build\n", stderr);
                   return 1;
                 }});
}

}  // namespace stend::cli
