#include "stend/testing/paths.hpp"

namespace fs = std::filesystem;

namespace stend::testing {

fs::path source_path(const fs::path& relative) { return fs::path(STEND_SOURCE_DIR) / relative; }

fs::path stend_program() { return fs::path(STEND_BINARY_DIR) / "bin" / "stend"; }

fs::path shared_data_dir() { return fs::path(STEND_SHARED_DATA_DIR); }

fs::path shared_data(const fs::path& relative) { return shared_data_dir() / relative; }

namespace {

bool inside(const fs::path& path, const fs::path& dir) {
  const fs::path rel = path.lexically_normal().lexically_relative(dir.lexically_normal());
  return !rel.empty() && *rel.begin() != "..";
}

}  // namespace

std::string why_absent(const fs::path& path) {
  if (fs::exists(path)) return {};
  std::string why = "skipped: " + path.string() + " is absent";
  if (inside(path, shared_data_dir())) {
    why += fs::is_directory(shared_data_dir())
               ? " from the shared data folder"
               : " (there is no shared data folder " + shared_data_dir().string() +
                     "; the CMake cache variable STEND_SHARED_DATA_DIR names where it is)";
  }
  return why;
}

}  // namespace stend::testing
