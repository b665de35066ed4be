// A C++ plugin whose entry point throws (it must not: it is a C function). The host survives.
#include <stend/plugin_abi.h>

#include <stdexcept>

extern "C" __attribute__((visibility("default"))) const stend_plugin_info* stend_plugin_entry() {
  throw std::runtime_error("entry point exploded");
}
