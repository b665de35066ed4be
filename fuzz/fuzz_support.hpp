// Shared by every fuzz target: the input cap and a scratch folder of the process's own.
// A target writes its input only into scratch_dir() (removed when the process exits) and ignores
// inputs longer than kMaxInputBytes, so each run stays small and fast.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace stend::fuzz {

// Longest input a target reads [bytes]; libFuzzer's -max_len is set to it by scripts/fuzz.sh.
inline constexpr std::size_t kMaxInputBytes = 64 * 1024;

// A fresh folder under the system temp dir (stend-fuzz-XXXXXX), made on first use and removed with
// everything in it at exit.
const std::filesystem::path& scratch_dir();

// Writes data[0 .. size) as scratch_dir()/name (created or truncated) and returns its path.
std::filesystem::path write_input(const std::uint8_t* data, std::size_t size, const std::string& name);

}  // namespace stend::fuzz
