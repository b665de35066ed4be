// Result files written whole through a checked temporary file (see files.hpp).
#include "stend/recording/files.hpp"

#include "stend/errors.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

namespace stend {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& file, const char* step, int err) {
  throw IoError(fmt::format("cannot write {}: {}{}", file.string(), step, std::strerror(err)));
}

// Writes all of `content` to `fd`, retrying short writes.
void write_all(int fd, std::string_view content, const fs::path& file) {
  while (!content.empty()) {
    const ssize_t n = ::write(fd, content.data(), content.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(file, "write failed: ", errno);
    }
    content.remove_prefix(static_cast<std::size_t>(n));
  }
}

// Flushes the temporary file to the device: a full disk may only show here.
void sync_file(const fs::path& tmp, const fs::path& file) {
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail(file, "reopen for sync failed: ", errno);
  if (::fsync(fd) != 0 && errno != EINVAL) {  // EINVAL: a file that cannot be synced (no device)
    const int err = errno;
    ::close(fd);
    fail(file, "sync failed: ", err);
  }
  if (::close(fd) != 0) fail(file, "close failed: ", errno);
}

}  // namespace

void write_file_atomic(const fs::path& file, const std::function<void(const fs::path& tmp)>& write) {
  fs::path tmp = file;
  tmp += ".tmp";
  try {
    write(tmp);
    sync_file(tmp, file);
    if (::rename(tmp.c_str(), file.c_str()) != 0) fail(file, "rename from .tmp failed: ", errno);
  } catch (...) {
    ::unlink(tmp.c_str());
    throw;
  }
}

void write_file_atomic(const fs::path& file, std::string_view content) {
  write_file_atomic(file, [&](const fs::path& tmp) {
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) fail(file, "", errno);
    try {
      write_all(fd, content, file);
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (::close(fd) != 0) fail(file, "close failed: ", errno);
  });
}

}  // namespace stend
