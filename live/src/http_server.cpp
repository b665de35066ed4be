// The live view's HTTP server on cpp-httplib (http_server.hpp: why it is a module of its own):
// bounded connections, deadlines and byte budgets per request, the Host check, and the routes —
// the embedded page and /api/state.
#include "http_server.hpp"

#include "stend/errors.hpp"
#include "web_assets.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string_view>
#include <thread>
#include <vector>

namespace stend::live {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kListenBacklog = 128;  // connections the kernel holds before they are accepted

std::string content_type(std::string_view url) {
  const auto ends = [&](std::string_view tail) {
    return url.size() >= tail.size() && url.substr(url.size() - tail.size()) == tail;
  };
  if (ends(".js")) return "text/javascript; charset=utf-8";
  if (ends(".css")) return "text/css; charset=utf-8";
  return "text/html; charset=utf-8";
}

// ---- the Host check ----------------------------------------------------------------------------

// The host part of a Host header: "[::1]:8765" → "::1", "localhost:8765" → "localhost", lower case.
std::string host_name(std::string host) {
  std::transform(host.begin(), host.end(), host.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (!host.empty() && host.front() == '[') {
    const auto close = host.find(']');
    return close == std::string::npos ? std::string() : host.substr(1, close - 1);
  }
  const auto colon = host.find(':');
  if (colon != std::string::npos && host.find(':', colon + 1) == std::string::npos) host.resize(colon);
  return host;
}

bool is_loopback_literal(const std::string& name) {
  in_addr v4{};
  if (inet_pton(AF_INET, name.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;  // 127.0.0.0/8
  in6_addr v6{};
  return inet_pton(AF_INET6, name.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

// Whether a request's Host names this machine's loopback or the address the server is bound to:
// a page served under another name (DNS rebinding) is refused.
bool host_allowed(const std::string& header, const std::string& bound) {
  const std::string name = host_name(header);
  return name == "localhost" || is_loopback_literal(name) || (!name.empty() && name == host_name(bound));
}

// ---- one connection: reads and writes within its deadline and byte budget ----------------------

// A connection's socket as httplib's Stream: every read and write waits at most until the
// connection's deadline, and no more than `max_bytes` are read from it in all.
class DeadlineStream final : public httplib::Stream {
 public:
  DeadlineStream(int fd, Clock::time_point deadline, std::size_t max_bytes)
      : fd_(fd), deadline_(deadline), max_bytes_(max_bytes) {}

  bool is_readable() const override { return pos_ < end_ || wait_for(POLLIN); }
  bool is_writable() const override { return wait_for(POLLOUT); }

  ssize_t read(char* ptr, size_t size) override {
    if (pos_ == end_ && !fill()) return -1;
    const std::size_t n = std::min(size, end_ - pos_);
    std::memcpy(ptr, buf_ + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!wait_for(POLLOUT)) return -1;
    return ::send(fd_, ptr, size, MSG_NOSIGNAL);
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address_of(::getpeername, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address_of(::getsockname, ip, port); }
  socket_t socket() const override { return fd_; }

 private:
  // Waits for `events` until the deadline; false when it passed or the socket failed.
  bool wait_for(short events) const {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{fd_, events, 0};
      const int r = ::poll(&p, 1, static_cast<int>(left));
      if (r < 0 && errno == EINTR) continue;
      return r > 0;
    }
  }

  // Refills the buffer from the socket; false at the deadline, the end, an error or the budget.
  bool fill() {
    if (read_ >= max_bytes_ || !wait_for(POLLIN)) return false;
    const std::size_t want = std::min(sizeof buf_, max_bytes_ - read_);
    const ssize_t n = ::recv(fd_, buf_, want, 0);
    if (n <= 0) return false;
    read_ += static_cast<std::size_t>(n);
    pos_ = 0;
    end_ = static_cast<std::size_t>(n);
    return true;
  }

  template <typename F>
  void address_of(F get, std::string& ip, int& port) const {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    ip.clear();
    port = 0;
    if (get(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0) return;
    char text[INET6_ADDRSTRLEN] = {};
    if (a.ss_family == AF_INET) {
      const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
      inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
      port = ntohs(v4->sin_port);
    } else if (a.ss_family == AF_INET6) {
      const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
      inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
      port = ntohs(v6->sin6_port);
    }
    ip = text;
  }

  int fd_;
  Clock::time_point deadline_;
  std::size_t max_bytes_;
  std::size_t read_ = 0;
  char buf_[4096];
  std::size_t pos_ = 0, end_ = 0;
};

// ---- the open connections: cut at once on stop, the oldest cut when all are taken --------------

class Connections {
 public:
  // Registers a connection being served; false once stopping, or when it is owed a cut (below):
  // it is then closed unserved.
  bool add(int fd) {
    const std::lock_guard<std::mutex> lock(m_);
    if (stopping_) return false;
    if (owed_cuts_ > 0) {
      --owed_cuts_;
      return false;
    }
    opened_[fd] = Clock::now();
    return true;
  }
  void remove(int fd) {
    const std::lock_guard<std::mutex> lock(m_);
    opened_.erase(fd);
  }
  // Cuts the connection open longest: its thread ends within a poll, free for a new client. In a
  // burst the workers may not have registered their connections yet; the next to register is then
  // the oldest and is owed the cut (without it, the burst's idle connections, queued ahead of a
  // new client, would each hold a worker to its deadline first).
  void cut_oldest() {
    const std::lock_guard<std::mutex> lock(m_);
    const auto oldest = std::min_element(opened_.begin(), opened_.end(),
                                         [](const auto& a, const auto& b) { return a.second < b.second; });
    if (oldest == opened_.end()) {
      ++owed_cuts_;
      return;
    }
    ::shutdown(oldest->first, SHUT_RDWR);
    opened_.erase(oldest);
  }
  // Cuts every connection and refuses new ones: no client is waited for.
  void cut_all() {
    const std::lock_guard<std::mutex> lock(m_);
    stopping_ = true;
    for (const auto& [fd, since] : opened_) ::shutdown(fd, SHUT_RDWR);
    opened_.clear();
  }

 private:
  std::mutex m_;
  std::map<int, Clock::time_point> opened_;
  std::size_t owed_cuts_ = 0;  // cuts asked for while no connection was registered
  bool stopping_ = false;
};

// ---- the worker threads: a fixed number, none ever queued behind a busy one --------------------

thread_local bool t_refuse_connection = false;  // set while a connection is closed unserved

// httplib's task queue with `threads` workers: a connection that finds them all busy makes room
// by cutting the oldest connection (`make_room`) and waits for that worker; beyond one queued
// connection per worker it is closed unserved at once, on the accepting thread.
class BoundedPool final : public httplib::TaskQueue {
 public:
  BoundedPool(std::size_t threads, std::function<void()> make_room) : make_room_(std::move(make_room)) {
    for (std::size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  void enqueue(std::function<void()> fn) override {
    {
      std::unique_lock<std::mutex> lock(m_);
      if (busy_ + jobs_.size() >= threads_.size()) {
        lock.unlock();
        make_room_();
        lock.lock();
      }
      if (jobs_.size() < threads_.size()) {
        jobs_.push_back(std::move(fn));
        cv_.notify_one();
        return;
      }
    }
    t_refuse_connection = true;
    fn();
    t_refuse_connection = false;
  }
  void shutdown() override {
    {
      const std::lock_guard<std::mutex> lock(m_);
      shutdown_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }

 private:
  void work() {
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      cv_.wait(lock, [this] { return shutdown_ || !jobs_.empty(); });
      if (jobs_.empty()) return;  // shutting down, nothing left
      std::function<void()> fn = std::move(jobs_.front());
      jobs_.pop_front();
      ++busy_;
      lock.unlock();
      fn();
      lock.lock();
      --busy_;
    }
  }

  std::function<void()> make_room_;
  std::vector<std::thread> threads_;
  std::deque<std::function<void()>> jobs_;
  std::size_t busy_ = 0;
  bool shutdown_ = false;
  std::mutex m_;
  std::condition_variable cv_;
};

// httplib's server with each connection served by DeadlineStream (one request, then closed) and
// registered in Connections.
class BoundedServer final : public httplib::Server {
 public:
  explicit BoundedServer(const LiveServerLimits& limits) : limits_(limits) {
    new_task_queue = [this] {
      return new BoundedPool(static_cast<std::size_t>(limits_.max_connections), [this] { connections_.cut_oldest(); });
    };
  }
  void cut_all_connections() { connections_.cut_all(); }
  // httplib listens with a backlog of 5: a burst of connections (a page's assets, a reload) would
  // see SYNs dropped and retried a second later. Listening again widens it.
  void widen_backlog() { ::listen(svr_sock_, kListenBacklog); }

 private:
  bool process_and_close_socket(socket_t sock) override {
    const bool serve = !t_refuse_connection && connections_.add(sock);
    if (serve) {
      serve_one_request(sock);
      connections_.remove(sock);
    } else {
      refuse_busy(sock);
    }
    ::shutdown(sock, SHUT_RDWR);
    ::close(sock);
    return serve;
  }

  void serve_one_request(int sock) {
    const auto deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(limits_.request_deadline_s));
    DeadlineStream stream(sock, deadline, limits_.max_request_bytes);
    bool closed = false;
    process_request(stream, /*close_connection=*/true, closed, nullptr);
  }

  // Says 503 without waiting (the socket's buffer takes it, or nothing is said) and closes.
  static void refuse_busy(int sock) {
    static constexpr std::string_view kBusy =
        "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 5\r\nConnection: close\r\n\r\nbusy\n";
    (void)::send(sock, kBusy.data(), kBusy.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  }

  LiveServerLimits limits_;
  Connections connections_;
};

bool read_only(const std::string& method) { return method == "GET" || method == "HEAD"; }

bool has_body(const httplib::Request& req) {
  return req.has_header("Transfer-Encoding") ||
         (req.has_header("Content-Length") && req.get_header_value("Content-Length") != "0");
}

void refuse(httplib::Response& res, int status, const std::string& why) {
  res.status = status;
  res.set_header("Connection", "close");
  res.set_content(why, "text/plain");
}

// Refuses, before any body is read: a method other than GET/HEAD (405), a body (413), a Host that
// does not name this machine (403).
httplib::Server::HandlerResponse screen(const httplib::Request& req, httplib::Response& res, const std::string& bound) {
  if (!read_only(req.method)) {
    res.set_header("Allow", "GET, HEAD");
    refuse(res, 405, "the live view is read-only\n");
  } else if (has_body(req)) {
    refuse(res, 413, "the live view takes no request body\n");
  } else if (!host_allowed(req.get_header_value("Host"), bound)) {
    refuse(res, 403, "the live view answers only to localhost, a loopback address or the address it is bound to\n");
  } else {
    return httplib::Server::HandlerResponse::Unhandled;
  }
  return httplib::Server::HandlerResponse::Handled;
}

}  // namespace

namespace {

void add_routes(httplib::Server& s, const std::function<std::string()>& state_json, const std::string& bound) {
  // Read-only: only GET (and HEAD) are routed; the page loads nothing from elsewhere.
  s.set_default_headers({{"Cache-Control", "no-store"},
                         {"X-Content-Type-Options", "nosniff"},
                         {"Content-Security-Policy", "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'"}});
  s.set_pre_routing_handler([bound](const httplib::Request& req, httplib::Response& res) { return screen(req, res, bound); });
  for (const WebAsset& a : web_assets()) {
    const std::string url(a.url);
    const std::string type = content_type(a.url);
    const std::string_view bytes = a.bytes;
    s.Get(url, [bytes, type](const httplib::Request&, httplib::Response& res) {
      res.set_content(bytes.data(), bytes.size(), type.c_str());
    });
  }
  s.Get("/api/state", [&state_json](const httplib::Request&, httplib::Response& res) {
    res.set_content(state_json(), "application/json");
  });
}

// httplib's own limits set to ours: no body, timeouts no longer than a connection's deadline.
void set_limits(httplib::Server& s, const LiveServerLimits& limits) {
  const auto deadline = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::duration<double>(limits.request_deadline_s));
  s.set_payload_max_length(0);
  s.set_read_timeout(deadline);
  s.set_write_timeout(deadline);
  s.set_keep_alive_max_count(1);
}

}  // namespace

// ---- the module's entry points (http_server.hpp) --------------------------------------------------

struct HttpServer {
  explicit HttpServer(const LiveServerOptions& options, std::function<std::string()> json)
      : server(options.limits), state_json(std::move(json)) {}
  BoundedServer server;
  std::function<std::string()> state_json;  // read by the /api/state handler on the server's threads
  std::thread thread;
  std::atomic<bool> listening_ended{false};
  int port = 0;
};

}  // namespace stend::live

extern "C" __attribute__((visibility("default"))) void* stend_live_http_start(const stend::live::LiveServerOptions* options,
                                                                            std::function<std::string()>* state_json, int* port) {
  using namespace stend::live;
  auto http = std::make_unique<HttpServer>(*options, std::move(*state_json));
  httplib::Server& s = http->server;
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, which would let a second stend listen
  // on a port that is taken (and share its requests) instead of being told so.
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  set_limits(s, options->limits);
  add_routes(s, http->state_json, options->address);
  if (options->port == 0) {
    http->port = s.bind_to_any_port(options->address);
    if (http->port <= 0)
      throw stend::IoError(fmt::format("live view: cannot listen on {} (any port); check the address", options->address));
  } else {
    if (!s.bind_to_port(options->address, options->port))
      throw stend::IoError(fmt::format("live view: cannot listen on {}:{} (in use?); choose another with --port, or "
                                       "--port 0 for any free port",
                                       options->address, options->port));
    http->port = options->port;
  }
  http->server.widen_backlog();
  http->thread = std::thread([h = http.get()] {
    h->server.listen_after_bind();
    h->listening_ended = true;
  });
  *port = http->port;
  return http.release();
}

// stop() is a no-op before the thread has started listening: wait for that first. Open
// connections are cut first, so that no worker waits on a client.
extern "C" __attribute__((visibility("default"))) void stend_live_http_stop(void* server) {
  std::unique_ptr<stend::live::HttpServer> http(static_cast<stend::live::HttpServer*>(server));
  while (!http->server.is_running() && !http->listening_ended) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  http->server.cut_all_connections();
  http->server.stop();
  if (http->thread.joinable()) http->thread.join();
}
