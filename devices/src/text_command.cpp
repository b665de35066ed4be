// SCPI-like text-command transport (see stend/devices/text_command.hpp).
#include <stend/devices/text_command.hpp>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <regex>
#include <thread>
#include <utility>

namespace stend::transport {
namespace {

speed_t baud_constant(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    default: return B0;
  }
}

// Connects the socket `fd` to `addr`, waiting at most `timeout_ms`; "" or why not. The wait is a
// poll on a non-blocking connect, so a signal arriving meanwhile (a stop request, a timer) is
// waited through instead of failing the connection, and an address that never answers ends at
// the time-out instead of the kernel's two minutes of SYN retries.
std::string connect_within(int fd, const sockaddr* addr, socklen_t addr_len, int timeout_ms) {
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) return std::strerror(errno);
  if (::connect(fd, addr, addr_len) != 0 && errno != EINPROGRESS && errno != EINTR) return std::strerror(errno);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return "no answer within " + std::to_string(timeout_ms) + " ms";
    pollfd p{fd, POLLOUT, 0};
    const int r = ::poll(&p, 1, static_cast<int>(left.count()));
    if (r > 0) break;
    if (r < 0 && errno != EINTR) return std::strerror(errno);
  }
  int err = 0;
  socklen_t err_len = sizeof err;
  if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &err_len) != 0) return std::strerror(errno);
  if (err != 0) return std::strerror(err);
  return ::fcntl(fd, F_SETFL, flags) == 0 ? "" : std::strerror(errno);
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '\r') out += "\\r";
    else if (ch == '\n') out += "\\n";
    else out += ch;
  }
  return out + "\"";
}

}  // namespace

bool TextCommandConfig::IsValid(std::string* error) const {
  if (terminator.empty()) return invalid(error, "the terminator must not be empty");
  if (host.empty() && device.empty()) return invalid(error, "give a TCP host and port or a serial device");
  if (!host.empty() && !(port >= 1 && port <= 65535)) return invalid(error, "port must be 1..65535");
  if (host.empty() && !(baud > 0)) return invalid(error, "baud must be > 0");
  if (!(timeout_ms > 0)) return invalid(error, "timeout_ms must be > 0");
  if (!(retries >= 0 && backoff_initial_ms >= 0)) return invalid(error, "retries and backoff_initial_ms must be >= 0");
  return true;
}

TextCommandClient::TextCommandClient(TextCommandConfig config) : c_(require_valid(config, "text command")) {
  if (c_.connect_now) {
    const std::string why = open_link();
    if (!why.empty())
      throw TextCommandError("text command " + where() + ": cannot connect (" + why +
                                 "); check the address/port or device path and that the controller is on",
                             TextCommandError::Kind::kOpen);
  }
}

TextCommandClient::~TextCommandClient() { close_link(); }

std::string TextCommandClient::where() const {
  if (!c_.host.empty()) return "tcp " + c_.host + ":" + std::to_string(c_.port);
  return "serial " + c_.device;
}

void TextCommandClient::close_link() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  pending_.clear();
}

std::string TextCommandClient::open_link() {
  close_link();
  if (!c_.host.empty()) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    const std::string port = std::to_string(c_.port);
    const int gai = ::getaddrinfo(c_.host.c_str(), port.c_str(), &hints, &res);
    if (gai != 0) return std::string("cannot resolve: ") + ::gai_strerror(gai);
    std::string why = "no address";
    for (addrinfo* a = res; a != nullptr; a = a->ai_next) {
      const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (fd < 0) {
        why = std::strerror(errno);
        continue;
      }
      why = connect_within(fd, a->ai_addr, a->ai_addrlen, c_.timeout_ms);
      if (why.empty()) {
        const int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        fd_ = fd;
        break;
      }
      ::close(fd);
    }
    ::freeaddrinfo(res);
    return fd_ >= 0 ? "" : why;
  }
  const speed_t speed = baud_constant(c_.baud);
  if (speed == B0) return "unsupported baud rate " + std::to_string(c_.baud);
  int fd = -1;
  do fd = ::open(c_.device.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  while (fd < 0 && errno == EINTR);
  if (fd < 0) return std::strerror(errno);
  termios t{};
  if (::tcgetattr(fd, &t) == 0) {
    ::cfmakeraw(&t);
    ::cfsetispeed(&t, speed);
    ::cfsetospeed(&t, speed);
    t.c_cflag |= CLOCAL | CREAD;
    ::tcsetattr(fd, TCSANOW, &t);
  }
  fd_ = fd;
  return "";
}

bool TextCommandClient::write_all(const std::string& bytes, std::string& why) {
  std::size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t n = c_.host.empty() ? ::write(fd_, bytes.data() + off, bytes.size() - off)
                                      : ::send(fd_, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      why = std::string("write failed: ") + std::strerror(errno);
      return false;
    }
    off += static_cast<std::size_t>(n);
  }
  return true;
}

bool TextCommandClient::read_line(std::string& line, std::string& why, TextCommandError::Kind& kind) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(c_.timeout_ms);
  for (;;) {
    const std::size_t pos = pending_.find(c_.terminator);
    if (pos != std::string::npos) {
      line = pending_.substr(0, pos);
      pending_.erase(0, pos + c_.terminator.size());
      while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
      while (!line.empty() && (line.front() == '\r' || line.front() == '\n')) line.erase(0, 1);
      return true;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      why = "no reply within " + std::to_string(c_.timeout_ms) + " ms" +
            (pending_.empty() ? "" : " (partial reply " + quoted(pending_) + ")");
      kind = TextCommandError::Kind::kTimeout;
      return false;
    }
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(left.count()));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) continue;  // time-out handled at the top
    char buf[512];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0) {
      pending_.append(buf, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    why = n == 0 ? "the peer closed the connection" : std::string("read failed: ") + std::strerror(errno);
    kind = TextCommandError::Kind::kDisconnected;
    return false;
  }
}

std::string TextCommandClient::transact(const std::string& command, bool want_reply) {
  int wait_ms = c_.backoff_initial_ms;
  for (int attempt = 0;; ++attempt) {
    std::string why;
    TextCommandError::Kind kind = TextCommandError::Kind::kDisconnected;
    bool ok = true;
    if (fd_ < 0) {
      why = open_link();
      if (!why.empty()) {
        why = "cannot connect: " + why;
        ok = false;
      } else if (attempt > 0 || stats_.commands > 0) {
        ++stats_.reconnects;
      }
    }
    std::string line;
    if (ok) {
      // A reply that arrived after an earlier time-out belongs to that command: drop it.
      pending_.clear();
      pollfd p{fd_, POLLIN, 0};
      while (::poll(&p, 1, 0) > 0 && (p.revents & POLLIN)) {
        char buf[512];
        const ssize_t n = ::read(fd_, buf, sizeof buf);
        if (n <= 0) {
          close_link();
          why = "the peer closed the connection";
          ok = false;
          break;
        }
      }
    }
    if (ok) ok = write_all(command + c_.terminator, why);
    if (ok && want_reply) ok = read_line(line, why, kind);
    if (ok) {
      ++stats_.commands;
      return line;
    }
    if (kind == TextCommandError::Kind::kTimeout) ++stats_.timeouts;
    // A broken or out-of-step link: start over on a fresh connection.
    if (kind != TextCommandError::Kind::kTimeout || !c_.host.empty()) close_link();
    std::string what = "text command " + where() + ": " + quoted(command) + " failed: " + why;
    if (attempt < c_.retries) {
      stats_.last_error = what + " — retrying";
      ++stats_.retries;
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      wait_ms *= 2;
      continue;
    }
    what += " after " + std::to_string(attempt + 1) + " attempts";
    stats_.last_error = what;
    ++stats_.failures;
    throw TextCommandError(what, kind);
  }
}

std::string TextCommandClient::query(const std::string& command) { return transact(command, true); }
void TextCommandClient::send(const std::string& command) { (void)transact(command, false); }

std::string expand_template(const std::string& templ, const std::map<std::string, std::string>& vars) {
  std::string out;
  for (std::size_t i = 0; i < templ.size(); ++i) {
    const char ch = templ[i];
    if (ch == '{' && i + 1 < templ.size() && templ[i + 1] == '{') {
      out += '{';
      ++i;
    } else if (ch == '}' && i + 1 < templ.size() && templ[i + 1] == '}') {
      out += '}';
      ++i;
    } else if (ch == '{') {
      const std::size_t end = templ.find('}', i);
      if (end == std::string::npos) throw std::invalid_argument("template \"" + templ + "\": unclosed '{'");
      const std::string name = templ.substr(i + 1, end - i - 1);
      const auto it = vars.find(name);
      if (it == vars.end())
        throw std::invalid_argument("template \"" + templ + "\": unknown placeholder {" + name + "}");
      out += it->second;
      i = end;
    } else {
      out += ch;
    }
  }
  return out;
}

double parse_number(const std::string& reply, const std::string& pattern, const std::string& what) {
  std::smatch m;
  const std::regex re(pattern);
  if (std::regex_search(reply, m, re)) {
    const std::string text = m.size() > 1 ? m[1].str() : m[0].str();
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() && *end == '\0') return v;
  }
  throw TextCommandError(what + ": cannot read a number from the reply " + quoted(reply) + " with the pattern " +
                             quoted(pattern),
                         TextCommandError::Kind::kParse);
}

}  // namespace stend::transport
