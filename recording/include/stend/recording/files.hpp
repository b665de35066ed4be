// The one way a command writes a result file (results JSON and text, reports, exports, run
// metadata): whole, through a temporary file in the destination folder, every step checked.
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>

namespace stend {

// Writes `content` as the whole of `file`: into `file`.tmp in the same folder, synced, closed and
// renamed over `file`, so a reader sees the old content or the new, never a mix. Every write, the
// sync, the close and the rename are checked; on a failure the temporary file is removed and
// IoError is thrown naming `file` and the system's reason ("cannot write F: No such file or
// directory"). The folder is not created.
void write_file_atomic(const std::filesystem::path& file, std::string_view content);

// The same for a library that writes a file by its name (e.g. matio): `write(tmp)` creates and
// fills the temporary file (and throws when it cannot); it is then synced and renamed as above.
void write_file_atomic(const std::filesystem::path& file,
                       const std::function<void(const std::filesystem::path& tmp)>& write);

}  // namespace stend
