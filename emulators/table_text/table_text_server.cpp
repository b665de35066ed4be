#include "table_text_server.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "stend/emulators/steady_ns.hpp"

namespace stend::emu {
namespace {

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

bool TableTextConfig::IsValid(std::string* error) const {
  if (axes.empty()) return invalid(error, "no axes");
  if (!(speed > 0.0)) return invalid(error, "speed must be > 0");
  if (!(port >= 0 && port <= 65535)) return invalid(error, "port must be 0..65535 (0: any free port)");
  for (const sim::AxisConfig& a : axes) {
    std::string why;
    if (!a.IsValid(&why)) return invalid(error, "axis '" + a.name + "': " + why);
  }
  return true;
}

// The config is refused before anything listens.
TableTextServer::TableTextServer(TableTextConfig c)
    : c_(require_valid(c, "table emulator")),
      t0_(std::chrono::steady_clock::now()),
      tcp_("table emulator", LoopbackTcpOptions{.port = c_.port, .poll_ms = 5, .down_sleep_ms = 5}) {
  for (std::size_t i = 0; i < c_.axes.size(); ++i) {
    axes_.emplace_back(c_.axes[i], c_.seed + i);
    axes_.back().start_at(0.0);
  }
  thread_ = std::thread([this] { run(); });
}

TableTextServer::~TableTextServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
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
  silent_until_ns_ = steady_ns_after(d);
}
void TableTextServer::garble_next(int replies) { garble_ = replies; }

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
    const auto ev = tcp_.wait();
    if (!ev) continue;
    if (ev->accepted_fd >= 0) {
      inbox_[ev->accepted_fd].clear();  // a new connection (its fd number may be a closed one's)
      connections_.fetch_add(1);
    }
    for (const int fd : ev->readable) {
      char buf[512];
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n <= 0) {
        tcp_.drop(fd);
        inbox_.erase(fd);
        continue;
      }
      std::string& inbox = inbox_[fd];
      inbox.append(buf, static_cast<std::size_t>(n));
      std::size_t nl;
      while ((nl = inbox.find('\n')) != std::string::npos) {
        const std::string line = inbox.substr(0, nl);
        inbox.erase(0, nl + 1);
        if (steady_now_ns() < silent_until_ns_.load()) continue;
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
        const ssize_t w = ::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL);
        (void)w;
      }
    }
  }
}

}  // namespace stend::emu
