#include "stend/core/modules.hpp"

#include <dlfcn.h>

#include <cstring>
#include <filesystem>

namespace stend {

std::string module_path(const std::string& file) {
  std::string (*self)(const std::string&) = &module_path;
  void* address = nullptr;
  static_assert(sizeof address == sizeof self);
  std::memcpy(&address, &self, sizeof address);
  Dl_info info{};
  if (::dladdr(address, &info) == 0 || info.dli_fname == nullptr || *info.dli_fname == '\0')
    return file;  // not found: the bare name, for dlopen's own search
  return (std::filesystem::path(info.dli_fname).parent_path() / file).string();
}

}  // namespace stend
