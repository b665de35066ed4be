#include "stend/live/server.hpp"

#include "stend/live/live_state.hpp"

#include "http_server.hpp"
#include "stend/core/modules.hpp"
#include "stend/errors.hpp"

#include <fmt/format.h>
#include <stend/on_demand.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>

#include <functional>

namespace stend::live {

namespace {

bool is_ip_literal(const std::string& address) {
  unsigned char buf[sizeof(in6_addr)];
  return inet_pton(AF_INET, address.c_str(), buf) == 1 || inet_pton(AF_INET6, address.c_str(), buf) == 1;
}

// The HTTP server (cpp-httplib, and through it OpenSSL) lives in its own library, opened when a
// live view is first served (core/on_demand/): every other command starts without them.
struct HttpModule {
  OnDemandLibrary lib{module_path(STEND_LIVE_HTTP_MODULE).c_str(), "the live view"};
  STEND_ON_DEMAND(lib, stend_live_http_start);
  STEND_ON_DEMAND(lib, stend_live_http_stop);
};
const HttpModule& http_module() {
  static const HttpModule module;
  return module;
}

}  // namespace

bool LiveServerOptions::IsValid(std::string* error) const {
  std::string why;
  if (!is_ip_literal(address))
    why = fmt::format("live view: '{}' is not an IP address; give one such as 127.0.0.1 (the default, loopback only)",
                      address);
  else if (port < 0 || port > 65535)
    why = fmt::format("live view: port {} is outside 0…65535 (0 picks a free port)", port);
  else if (limits.max_connections < 1 || !(limits.request_deadline_s > 0.0) || limits.max_request_bytes < 1024)
    why = "live view: limits must allow one connection, a deadline above 0 s and requests of 1024 bytes";
  if (error != nullptr) *error = why;
  return why.empty();
}

bool charts_built_in() { return STEND_LIVE_CHARTS != 0; }

struct LiveServer::Impl {
  void* http = nullptr;  // the module's server
  std::string address;
  int port = 0;
};

LiveServer::LiveServer(const LiveState& state, const LiveServerOptions& options) : impl_(std::make_unique<Impl>()) {
  if (std::string why; !options.IsValid(&why)) throw InputError(why);
  std::function<std::string()> state_json = [&state] { return state.to_json().dump(); };
  impl_->http = http_module().stend_live_http_start(&options, &state_json, &impl_->port);
  impl_->address = options.address;
}

LiveServer::~LiveServer() { http_module().stend_live_http_stop(impl_->http); }

int LiveServer::port() const { return impl_->port; }

std::string LiveServer::url() const {
  const bool v6 = impl_->address.find(':') != std::string::npos;
  return fmt::format("http://{}{}{}:{}/", v6 ? "[" : "", impl_->address, v6 ? "]" : "", impl_->port);
}

}  // namespace stend::live
