#pragma once
// Where Stend's own modules are: libraries of Stend that a command opens only when it needs them
// (the live view's HTTP server, libstend_live_http.so: live/src/http_server.hpp).
#include <string>

namespace stend {

// The absolute path of `file` in the folder libstend_core.so was loaded from (build/lib in the
// build tree, the install's library folder), where the modules are built and installed beside it.
// An absolute path, not a bare name: dlopen searches a bare name along its caller's run path, and
// under a sanitizer the caller is the sanitizer's interceptor, whose run path is not Stend's.
std::string module_path(const std::string& file);

}  // namespace stend
