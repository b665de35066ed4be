// Experiment YAML → Experiment: structure, types, units, steps and every plugin config checked
// against the schemas of the build tree's plugins (the plugin host's scan of its plugin folder;
// nothing is created). parse_experiment either returns an Experiment or throws ExperimentError.
#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>

#include <cstdint>
#include <exception>
#include <string>

#include "fuzz_support.hpp"

namespace {

const stend::PluginHost& host() {
  static const stend::PluginHost* h = [] {
    auto* p = new stend::PluginHost;  // lives as long as the process: plugins stay loaded
    p->scan({{STEND_BUILD_PLUGIN_DIR, "build tree"}});
    return p;
  }();
  return *h;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const stend::Experiment exp = stend::parse_experiment(text, "fuzz.yaml", host());
    (void)exp.resolved_yaml.size();
  } catch (const stend::ExperimentError&) {
  }
  return 0;
}
