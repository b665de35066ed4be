// The live view's HTTP server: read-only (GET only), on the loopback interface unless told
// otherwise, serving the page, its script and styles, the embedded charting library (uPlot,
// vendored at build time: live/CMakeLists.txt) and the state as JSON (GET /api/state). Bounded
// (LiveServerLimits, docs/live-view.md "Limits"): no client, slow, idle or hostile, can hold it,
// fill its memory, or keep it (and so the run serving it) from stopping.
#pragma once

// LiveState: stend/live/live_state.hpp (not included here: the HTTP module, src/http_server.hpp,
// needs only the options).

#include <cstddef>
#include <memory>
#include <string>

namespace stend::live {

class LiveState;

// What one client may take of the server; the defaults are the documented limits.
struct LiveServerLimits {
  int max_connections = 32;              // served at once (one thread each); a new one closes the oldest
  double request_deadline_s = 5.0;       // a connection's whole life: request read, answer written [s]
  std::size_t max_request_bytes = 65536; // request line and headers [bytes]; a request with a body is refused
};

struct LiveServerOptions {
  std::string address = "127.0.0.1";  // loopback only by default
  int port = 8765;                     // 0: any free port (LiveServer::port() says which)
  LiveServerLimits limits;
  // Whether the address is an IPv4 or IPv6 literal and 0 ≤ port ≤ 65535; when not, `error` (if
  // given) says which and what to give instead.
  bool IsValid(std::string* error = nullptr) const;
};

class LiveServer {
 public:
  // Binds and starts serving `state` on threads of its own: one request per connection, GET and
  // HEAD only (else 405), no body (else 413), a Host header naming a loopback address, localhost
  // or the bound address only (else 403: a page on another name, DNS rebinding, reads nothing).
  // Throws InputError for options that are not valid (IsValid), IoError naming the address and
  // port when it cannot bind (in use, not allowed).
  LiveServer(const LiveState& state, const LiveServerOptions& options);
  ~LiveServer();  // stops serving at once: open connections are cut, none is waited for
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
