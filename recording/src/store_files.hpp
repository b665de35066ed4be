// The file system calls of the run store, each checked: a failed write or read is an IoError
// naming the file and the system's reason. Internal to stend_recording.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace stend::detail {

// Writes all `n` bytes at `p` to `fd`, retrying short and interrupted writes.
void write_all(int fd, const char* p, std::size_t n, const std::filesystem::path& file);
// Creates `file` (it must not exist) holding `content`.
void write_new_file(const std::filesystem::path& file, std::string_view content);
// Syncs a folder's entries (the files created and renamed in it); best effort.
void fsync_dir(const std::filesystem::path& dir);
// The whole content of `file`: InputError when it cannot be opened, IoError when reading fails.
std::string read_whole_file(const std::filesystem::path& file);
// Throws InputError "FILE:LINE: WHAT".
[[noreturn]] void fail_at(const std::filesystem::path& file, std::size_t line, const std::string& what);
// "2024-05-01T12:00:00.123Z": the wall clock now, UTC, to the millisecond.
std::string utc_now_iso();

}  // namespace stend::detail
