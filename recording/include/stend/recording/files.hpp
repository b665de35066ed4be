// The one way a command writes a result file (results JSON and text, reports, exports, run
// metadata): whole, through a temporary file of its own in the destination folder, every step
// checked; and the lock that makes commands writing into one run folder take turns.
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>

namespace stend {

// Writes `content` as the whole of `file`: into a temporary file of this write's own in the same
// folder (FILE.XXXXXX.tmp, created exclusively, so two writers never share one), synced, closed
// and renamed over `file`, and the folder synced, so a reader sees the old content or the new,
// never a mix, and two concurrent writers each leave a whole file (the last rename wins). Every
// write, the sync, the close and the rename are checked; on a failure the temporary file is
// removed and IoError is thrown naming `file` and the system's reason ("cannot write F: No such
// file or directory"). The folder is not created.
void write_file_atomic(const std::filesystem::path& file, std::string_view content);

// The same for a library that writes a file by its name (e.g. matio): `write(tmp)` fills the
// temporary file (created empty, and throws when it cannot); it is then synced and renamed as above.
void write_file_atomic(const std::filesystem::path& file,
                       const std::function<void(const std::filesystem::path& tmp)>& write);

// The name of the lock file in a run folder.
inline constexpr const char* kRunLockFile = ".stend.lock";

// How long a command waits for another command to release a run folder [s].
inline constexpr double kRunLockWait_s = 600.0;

// An exclusive lock on a run folder, held while a command reads and rewrites its results (fit,
// report, gap, apply, export): flock(2) on RUN/.stend.lock, released when the object goes (or the
// process ends, however it ends). A second command on the same run waits its turn: `on_wait` is
// called once when it has to, then it waits up to kRunLockWait_s and throws IoError naming the run
// ("RUN is in use by another stend command …"). A folder where the lock file cannot be created
// (read-only, not a folder) is not locked: nothing can be written into it either.
class RunFolderLock {
 public:
  explicit RunFolderLock(const std::filesystem::path& run_dir, const std::function<void()>& on_wait = {});
  ~RunFolderLock();
  RunFolderLock(const RunFolderLock&) = delete;
  RunFolderLock& operator=(const RunFolderLock&) = delete;

  bool held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

}  // namespace stend
