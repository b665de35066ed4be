#include "stend/live/server.hpp"

#include "stend/errors.hpp"
#include "web_assets.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include <arpa/inet.h>
#include <sys/socket.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace stend::live {

namespace {

std::string content_type(std::string_view url) {
  const auto ends = [&](std::string_view tail) {
    return url.size() >= tail.size() && url.substr(url.size() - tail.size()) == tail;
  };
  if (ends(".js")) return "text/javascript; charset=utf-8";
  if (ends(".css")) return "text/css; charset=utf-8";
  return "text/html; charset=utf-8";
}

bool is_ip_literal(const std::string& address) {
  unsigned char buf[sizeof(in6_addr)];
  return inet_pton(AF_INET, address.c_str(), buf) == 1 || inet_pton(AF_INET6, address.c_str(), buf) == 1;
}

}  // namespace

bool LiveServerOptions::IsValid(std::string* error) const {
  std::string why;
  if (!is_ip_literal(address))
    why = fmt::format("live view: '{}' is not an IP address; give one such as 127.0.0.1 (the default, loopback only)",
                      address);
  else if (port < 0 || port > 65535)
    why = fmt::format("live view: port {} is outside 0…65535 (0 picks a free port)", port);
  if (error != nullptr) *error = why;
  return why.empty();
}

bool charts_built_in() { return STEND_LIVE_CHARTS != 0; }

struct LiveServer::Impl {
  httplib::Server server;
  std::thread thread;
  std::atomic<bool> listening_ended{false};
  std::string address;
  int port = 0;
};

LiveServer::LiveServer(const LiveState& state, const LiveServerOptions& options) : impl_(std::make_unique<Impl>()) {
  if (std::string why; !options.IsValid(&why)) throw InputError(why);
  httplib::Server& s = impl_->server;
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, which would let a second stend listen
  // on a port that is taken (and share its requests) instead of being told so.
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  // Read-only: only GET (and HEAD) are routed; the page loads nothing from elsewhere.
  s.set_default_headers({{"Cache-Control", "no-store"},
                         {"X-Content-Type-Options", "nosniff"},
                         {"Content-Security-Policy", "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'"}});
  for (const WebAsset& a : web_assets()) {
    const std::string url(a.url);
    const std::string type = content_type(a.url);
    const std::string_view bytes = a.bytes;
    s.Get(url, [bytes, type](const httplib::Request&, httplib::Response& res) {
      res.set_content(bytes.data(), bytes.size(), type.c_str());
    });
  }
  s.Get("/api/state", [&state](const httplib::Request&, httplib::Response& res) {
    res.set_content(state.to_json().dump(), "application/json");
  });
  const auto refuse = [](const httplib::Request&, httplib::Response& res) {
    res.status = 405;
    res.set_content("the live view is read-only\n", "text/plain");
  };
  s.Post(".*", refuse);
  s.Put(".*", refuse);
  s.Delete(".*", refuse);
  s.Patch(".*", refuse);

  impl_->address = options.address;
  if (options.port == 0) {
    impl_->port = s.bind_to_any_port(options.address);
    if (impl_->port <= 0)
      throw IoError(fmt::format("live view: cannot listen on {} (any port); check the address", options.address));
  } else {
    if (!s.bind_to_port(options.address, options.port))
      throw IoError(fmt::format("live view: cannot listen on {}:{} (in use?); choose another with --port, or "
                                "--port 0 for any free port",
                                options.address, options.port));
    impl_->port = options.port;
  }
  impl_->thread = std::thread([impl = impl_.get()] {
    impl->server.listen_after_bind();
    impl->listening_ended = true;
  });
}

// stop() is a no-op before the thread has started listening: wait for that first.
LiveServer::~LiveServer() {
  while (!impl_->server.is_running() && !impl_->listening_ended) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

int LiveServer::port() const { return impl_->port; }

std::string LiveServer::url() const {
  const bool v6 = impl_->address.find(':') != std::string::npos;
  return fmt::format("http://{}{}{}:{}/", v6 ? "[" : "", impl_->address, v6 ? "]" : "", impl_->port);
}

}  // namespace stend::live
