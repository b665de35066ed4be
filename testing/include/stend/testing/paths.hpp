// Where a test finds things: the source tree, the built `stend` program, and the shared data folder
// (real recordings kept beside the project, not in it) with the one rule for skipping a test whose
// shared data is absent.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace stend::testing {

// A file or folder of the source tree: source_path("configs/six_position.yaml").
std::filesystem::path source_path(const std::filesystem::path& relative);

// This build tree's `stend` program (bin/stend).
std::filesystem::path stend_program();

// The shared data folder: ../shared/data beside the source tree, or what the CMake cache variable
// STEND_SHARED_DATA_DIR names.
std::filesystem::path shared_data_dir();

// A file or folder inside it: shared_data("imucal/annotated_session.csv").
std::filesystem::path shared_data(const std::filesystem::path& relative);

// Why a test that reads `path` cannot run: empty when the path exists, else a message naming it
// (and, for a path in the shared data folder, whether the whole folder is absent).
std::string why_absent(const std::filesystem::path& path);

}  // namespace stend::testing

// Skips the running test (from its body or SetUp) when `path` is absent, naming the missing path:
//   const auto csv = stend::testing::shared_data("imucal/annotated_session.csv");
//   STEND_SKIP_IF_ABSENT(csv);
// More text may be streamed after it: STEND_SKIP_IF_ABSENT(csv) << "; real-data check skipped".
#define STEND_SKIP_IF_ABSENT(path)                                                                       \
  if (const std::string stend_why_absent_ = ::stend::testing::why_absent(path); stend_why_absent_.empty()) { \
  } else                                                                                                 \
    GTEST_SKIP() << stend_why_absent_
