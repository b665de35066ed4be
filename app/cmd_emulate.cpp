// `stend emulate` — placeholder until issue 4 lands; it is registered so the CLI shape is fixed.
#include "commands.hpp"

#include <cstdio>

namespace stend::cli {

void add_emulate_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("emulate", "(not yet available)");
  sub->allow_extras();
  out.push_back({sub, [] {
                   std::fputs("stend emulate: not yet available in this build\n", stderr);
                   return 1;
                 }});
}

}  // namespace stend::cli
