#include "table_text_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace stend::emu {
namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string upper(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return s;
}

std::string num(double v) {
  char b[48];
  std::snprintf(b, sizeof b, "%.6f", v);
  return b;
}

}  // namespace

TableTextServer::TableTextServer(TableTextConfig c) : c_(std::move(c)), t0_(std::chrono::steady_clock::now()) {
  if (c_.axes.empty()) throw std::invalid_argument("table emulator: no axes");
  if (!(c_.speed > 0.0)) throw std::invalid_argument("table emulator: speed must be > 0");
  for (std::size_t i = 0; i < c_.axes.size(); ++i) {
    axes_.emplace_back(c_.axes[i], c_.seed + i);
    axes_.back().start_at(0.0);
  }
  port_ = c_.port;
  if (!listen_now())
    throw std::runtime_error("table emulator: cannot listen on 127.0.0.1:" + std::to_string(c_.port) + ": " +
                             std::strerror(errno));
  thread_ = std::thread([this] { run(); });
}

TableTextServer::~TableTextServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  for (int fd : clients_) ::close(fd);
  if (listen_fd_ >= 0) ::close(listen_fd_);
}

double TableTextServer::emulated_now() const {
  return c_.speed * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void TableTextServer::advance_locked() const {
  const double t = emulated_now();
  for (auto& a : axes_) a.advance(t);
}

sim::AxisState TableTextServer::state(std::size_t i) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(i).at(emulated_now());
}

sim::AxisState TableTextServer::state_at(std::size_t i, double t) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(i).at(t);
}

double TableTextServer::commanded(std::size_t i) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(i).commanded();
}

void TableTextServer::go_silent(std::chrono::milliseconds d) {
  silent_until_ns_ = now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}
void TableTextServer::disconnect_for(std::chrono::milliseconds d) {
  down_until_ns_ = now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}
void TableTextServer::garble_next(int replies) { garble_ = replies; }

bool TableTextServer::listen_now() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port_));
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

std::string TableTextServer::execute(const std::string& raw) {
  const std::string line = trim(raw);
  if (line.empty()) return "";
  commands_.fetch_add(1);
  const auto sp = line.find(' ');
  const std::string head = upper(sp == std::string::npos ? line : line.substr(0, sp));
  const std::string args = sp == std::string::npos ? "" : trim(line.substr(sp + 1));
  auto error = [&](int code, const std::string& text) {
    if (errors_.size() < 16) errors_.push_back(std::to_string(code) + ",\"" + text + "\"");
    return std::string();
  };
  if (head == "*IDN?") return c_.identity;
  if (head == ":SYST:ERR?") {
    if (errors_.empty()) return "0,\"No error\"";
    std::string e = errors_.front();
    errors_.pop_front();
    return e;
  }
  // Axis argument (1-based) and optional value.
  char* end = nullptr;
  const long axis = std::strtol(args.c_str(), &end, 10);
  if (end == args.c_str() || axis < 1 || static_cast<std::size_t>(axis) > axes_.size()) {
    if (head.back() == '?') return "NaN";  // a query must be answered; the error queue says why
    return error(-114, "Header suffix out of range: no axis '" + args + "'");
  }
  sim::SimAxis& ax = axes_[static_cast<std::size_t>(axis - 1)];
  const double t = emulated_now();
  if (head == ":POS?") return num(ax.measured());
  if (head == ":RATE?") return num(ax.at(t).velocity);
  if (head == ":STOP") {
    ax.safe_state(t);
    return "";
  }
  if (head == ":POS" || head == ":RATE") {
    const char* p = end;
    while (*p == ' ' || *p == ',') ++p;
    char* vend = nullptr;
    const double v = std::strtod(p, &vend);
    if (vend == p) return error(-109, "Missing parameter");
    try {
      ax.command(head == ":POS" ? CommandMode::kPosition : CommandMode::kRate, v, t);
    } catch (const std::invalid_argument& e) {
      return error(-222, std::string("Data out of range: ") + e.what());
    }
    return "";
  }
  return error(-113, "Undefined header '" + head + "'");
}

void TableTextServer::run() {
  while (!stop_) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      advance_locked();
    }
    if (now_ns() < down_until_ns_.load()) {
      for (int fd : clients_) ::close(fd);
      clients_.clear();
      inbox_.clear();
      if (listen_fd_ >= 0) ::close(listen_fd_);
      listen_fd_ = -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    if (listen_fd_ < 0 && !listen_now()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    std::vector<pollfd> p;
    p.push_back({listen_fd_, POLLIN, 0});
    for (int fd : clients_) p.push_back({fd, POLLIN, 0});
    if (::poll(p.data(), p.size(), 5) <= 0) continue;
    if (p[0].revents & POLLIN) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) {
        clients_.push_back(fd);
        inbox_.emplace_back();
        connections_.fetch_add(1);
      }
    }
    for (std::size_t k = 1; k < p.size(); ++k) {
      if (!(p[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const std::size_t ci = k - 1;
      char buf[512];
      const ssize_t n = ::read(clients_[ci], buf, sizeof buf);
      if (n <= 0) {
        ::close(clients_[ci]);
        clients_[ci] = -1;
        continue;
      }
      inbox_[ci].append(buf, static_cast<std::size_t>(n));
      std::size_t nl;
      while ((nl = inbox_[ci].find('\n')) != std::string::npos) {
        const std::string line = inbox_[ci].substr(0, nl);
        inbox_[ci].erase(0, nl + 1);
        if (now_ns() < silent_until_ns_.load()) continue;
        std::string reply;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          advance_locked();
          reply = execute(line);
        }
        if (reply.empty()) continue;
        if (garble_.load() > 0) {
          garble_.fetch_sub(1);
          reply = "#\x7f~" + reply.substr(0, reply.size() / 2) + "?!";
        }
        reply += "\r\n";
        const ssize_t w = ::send(clients_[ci], reply.data(), reply.size(), MSG_NOSIGNAL);
        (void)w;
      }
    }
    for (std::size_t ci = clients_.size(); ci-- > 0;) {
      if (clients_[ci] < 0) {
        clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(ci));
        inbox_.erase(inbox_.begin() + static_cast<std::ptrdiff_t>(ci));
      }
    }
  }
}

}  // namespace stend::emu
