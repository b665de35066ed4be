// The live view's HTTP server: read-only (GET only), on the loopback interface unless told
// otherwise, serving the page, its script and styles, the embedded charting library (uPlot,
// vendored at build time: live/CMakeLists.txt) and the state as JSON (GET /api/state).
#pragma once

#include <stend/live/live_state.hpp>

#include <memory>
#include <string>

namespace stend::live {

struct LiveServerOptions {
  std::string address = "127.0.0.1";  // loopback only by default
  int port = 8765;                     // 0: any free port (LiveServer::port() says which)
  // Whether the address is an IPv4 or IPv6 literal and 0 ≤ port ≤ 65535; when not, `error` (if
  // given) says which and what to give instead.
  bool IsValid(std::string* error = nullptr) const;
};

class LiveServer {
 public:
  // Binds and starts serving `state` on a thread of its own. Throws InputError for options that
  // are not valid (IsValid), IoError naming the address and port when it cannot bind (in use, not
  // allowed).
  LiveServer(const LiveState& state, const LiveServerOptions& options);
  ~LiveServer();  // stops serving
  LiveServer(const LiveServer&) = delete;
  LiveServer& operator=(const LiveServer&) = delete;

  int port() const;
  std::string url() const;  // http://127.0.0.1:8765/

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Whether the charting library was embedded in this build (else the page shows numbers only).
bool charts_built_in();

}  // namespace stend::live
