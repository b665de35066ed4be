#include "stend/emulators/tcp_server.hpp"

#include <stend/errors.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>

#include "stend/emulators/steady_ns.hpp"

namespace stend::emu {

bool LoopbackTcpOptions::IsValid(std::string* error) const {
  if (!(port >= 0 && port <= 65535)) return invalid(error, "port must be 0..65535 (0: any free port)");
  if (!(poll_ms > 0)) return invalid(error, "poll_ms must be > 0");
  if (!(down_sleep_ms >= 0 && relisten_sleep_ms >= 0)) return invalid(error, "down_sleep_ms and relisten_sleep_ms must be >= 0");
  return true;
}

LoopbackTcpServer::LoopbackTcpServer(const char* who, LoopbackTcpOptions options)
    : o_(require_valid(options, who)), port_(options.port) {
  if (!listen_now())
    throw IoError(std::string(who) + ": cannot listen on 127.0.0.1:" + std::to_string(options.port) + ": " +
                  std::strerror(errno));
}

LoopbackTcpServer::~LoopbackTcpServer() { close_all(); }

void LoopbackTcpServer::disconnect_for(std::chrono::milliseconds d) { down_until_ns_ = steady_ns_after(d); }

bool LoopbackTcpServer::listen_now() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port_.load()));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 4) != 0) {
    ::close(fd);
    return false;
  }
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  listen_fd_ = fd;
  return true;
}

void LoopbackTcpServer::close_all() {
  for (int fd : clients_) ::close(fd);
  clients_.clear();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
}

void LoopbackTcpServer::drop(int fd) {
  const auto it = std::find(clients_.begin(), clients_.end(), fd);
  if (it == clients_.end()) return;
  ::close(fd);
  clients_.erase(it);
}

std::optional<LoopbackTcpServer::Events> LoopbackTcpServer::wait() {
  if (steady_now_ns() < down_until_ns_.load()) {  // the peer is gone: nothing listens, nothing answers
    close_all();
    std::this_thread::sleep_for(std::chrono::milliseconds(o_.down_sleep_ms));
    return std::nullopt;
  }
  if (listen_fd_ < 0 && !listen_now()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(o_.relisten_sleep_ms));
    return std::nullopt;
  }
  std::vector<pollfd> p;
  p.push_back({listen_fd_, POLLIN, 0});
  for (int fd : clients_) p.push_back({fd, POLLIN, 0});
  if (::poll(p.data(), p.size(), o_.poll_ms) <= 0) return std::nullopt;
  Events ev;
  for (std::size_t k = 1; k < p.size(); ++k) {
    if (p[k].revents & (POLLIN | POLLHUP | POLLERR)) ev.readable.push_back(p[k].fd);
  }
  if (p[0].revents & POLLIN) {
    ev.listener = true;
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd >= 0) {
      if (o_.newest_only) {  // one master at a time: the newest wins
        for (int c : clients_) ::close(c);
        clients_.clear();
        ev.readable.clear();
      }
      clients_.push_back(fd);
      ev.accepted_fd = fd;
    }
  }
  return ev;
}

}  // namespace stend::emu
