// Result files written whole through a checked temporary file of their own, and the run folder
// lock (see files.hpp).
#include "stend/recording/files.hpp"

#include "stend/errors.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

namespace stend {

namespace fs = std::filesystem;

namespace {

constexpr mode_t kResultFileMode = 0644;         // rw-r--r--, as open(…, 0644) gave before
constexpr const char* kTmpSuffix = ".tmp";
constexpr int kLockPoll_ms = 20;                 // how often a waiting command retries the lock [ms]

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

// A temporary file of this write's own beside `file` (FILE.XXXXXX.tmp, created exclusively with
// mode 0644): its path, and its descriptor open for writing.
int create_unique_tmp(const fs::path& file, fs::path& tmp) {
  std::string name = file.string() + ".XXXXXX" + kTmpSuffix;
  const int fd = ::mkostemps(name.data(), static_cast<int>(std::strlen(kTmpSuffix)), O_CLOEXEC);
  if (fd < 0) fail(file, "", errno);
  tmp = name;
  if (::fchmod(fd, kResultFileMode) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    fail(file, "chmod failed: ", err);
  }
  return fd;
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

// Makes the rename itself durable: syncs the folder's entry list. A folder that cannot be opened
// or synced (EINVAL, EACCES on some file systems) is left as it is: the file is already whole.
void sync_folder(const fs::path& file) {
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  (void)::fsync(fd);
  ::close(fd);
}

void rename_over(const fs::path& tmp, const fs::path& file) {
  if (::rename(tmp.c_str(), file.c_str()) != 0) fail(file, "rename from the temporary file failed: ", errno);
}

}  // namespace

void write_file_atomic(const fs::path& file, const std::function<void(const fs::path& tmp)>& write) {
  fs::path tmp;
  const int fd = create_unique_tmp(file, tmp);
  ::close(fd);  // the library opens it by name
  try {
    write(tmp);
    sync_file(tmp, file);
    rename_over(tmp, file);
  } catch (...) {
    ::unlink(tmp.c_str());
    throw;
  }
  sync_folder(file);
}

void write_file_atomic(const fs::path& file, std::string_view content) {
  fs::path tmp;
  const int fd = create_unique_tmp(file, tmp);
  try {
    write_all(fd, content, file);
    if (::fsync(fd) != 0 && errno != EINVAL) fail(file, "sync failed: ", errno);
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  try {
    if (::close(fd) != 0) fail(file, "close failed: ", errno);
    rename_over(tmp, file);
  } catch (...) {
    ::unlink(tmp.c_str());
    throw;
  }
  sync_folder(file);
}

namespace {

// The lock file's descriptor, or -1 when it cannot be opened (a read-only or missing folder).
int open_lock_file(const fs::path& run_dir) {
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec)) return -1;
  return ::open((run_dir / kRunLockFile).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, kResultFileMode);
}

// Tries the lock without waiting: true when held, false when another process holds it.
bool try_lock(int fd) {
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK) return false;
    return true;  // a file system without flock: nothing to take turns on
  }
  return true;
}

}  // namespace

RunFolderLock::RunFolderLock(const fs::path& run_dir, const std::function<void()>& on_wait) {
  const int fd = open_lock_file(run_dir);
  if (fd < 0) return;
  if (try_lock(fd)) {
    fd_ = fd;
    return;
  }
  if (on_wait) on_wait();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kRunLockWait_s);
  while (!try_lock(fd)) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::close(fd);
      throw IoError(fmt::format("{} is in use by another stend command (fit, report, gap, apply or export) and was "
                                "not released within {:.0f} s; run it again when that command has ended",
                                run_dir.string(), kRunLockWait_s));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(kLockPoll_ms));
  }
  fd_ = fd;
}

RunFolderLock::~RunFolderLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

}  // namespace stend
