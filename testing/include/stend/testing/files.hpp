// Scoped temporary folders and whole-file text reads and writes for tests.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace stend::testing {

// A fresh folder under the system temp dir (stend-TAG-XXXXXX, unique per process and call),
// removed with everything in it at the end of the scope. It is kept, and its path printed, when the
// running test (or, for a folder a suite shares, one of its tests) has failed or the environment sets
// STEND_KEEP_TEST_DIRS — for inspection.
class TempDir {
 public:
  explicit TempDir(const std::string& tag = "test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }
  std::filesystem::path operator/(const std::filesystem::path& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// The whole file, byte for byte; empty when it cannot be read.
std::string read_text(const std::filesystem::path& file);

// Writes `text` as the whole file (created or truncated), byte for byte.
void write_text(const std::filesystem::path& file, const std::string& text);

// The file's lines as rows of whitespace-separated numbers, read up to the first word that is not
// one (Stable32's result tables, PHASE.DAT); empty lines, lines starting with '#' and lines without
// a leading number are skipped. Empty when the file cannot be read.
std::vector<std::vector<double>> read_number_rows(const std::filesystem::path& file);

}  // namespace stend::testing
