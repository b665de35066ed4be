#pragma once
// The live view's HTTP server, a module of its own (libstend_live_http.so, opened by server.cpp
// when a live view is first served): cpp-httplib loads OpenSSL at start, which no other command
// needs. Its two entry points, looked up by name (stend/on_demand.hpp):
#include <stend/live/server.hpp>

#include <functional>
#include <string>

// Binds and starts serving (LiveServer's constructor says what is served and refused); the state's
// JSON comes from state_json (moved from), called on the server's threads. Returns the server, to
// be given to stend_live_http_stop, and its port; throws IoError when it cannot bind.
extern "C" void* stend_live_http_start(const stend::live::LiveServerOptions* options,
                                       std::function<std::string()>* state_json, int* port);
// Stops serving at once (open connections are cut, none is waited for) and frees the server.
extern "C" void stend_live_http_stop(void* server);
