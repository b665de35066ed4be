// SCPI-like text-command transport over TCP or a serial line: one command per line, ended by a
// terminator; a query waits for one reply line. Time-outs, retries with back-off and a broken
// link (peer closed, reset, device unplugged) are handled here; what a reply means is the
// caller's (see fixtures/evo10l: command templates and a response parser from YAML).
//
// Every failure is a TextCommandError naming the endpoint ("tcp 127.0.0.1:5025" or
// "serial /dev/ttyUSB0"), the command sent and the reason.
#pragma once

#include <stend/errors.hpp>

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

namespace stend::transport {

struct TextCommandConfig {
  std::string host{};        // TCP: host name or address (empty = serial)
  int port = 0;              // TCP port
  std::string device{};      // serial: "/dev/ttyUSB0" (used when host is empty)
  int baud = 115200;         // serial: 8N1, no flow control
  std::string terminator = "\n";  // appended to every command; ends every reply ("\r\n" accepted)
  int timeout_ms = 500;      // per reply, and per TCP connection attempt
  int retries = 2;           // extra attempts after a time-out or a broken link
  int backoff_initial_ms = 20;  // wait before the first retry; doubles each retry
  bool connect_now = true;   // false: the first command connects

  // A terminator; a TCP host (port 1..65535) or a serial device (baud > 0); a positive time-out,
  // no negative retries or back-off.
  bool IsValid(std::string* error = nullptr) const;
};

class TextCommandError : public IoError {
 public:
  enum class Kind { kOpen, kTimeout, kDisconnected, kDevice, kParse };
  TextCommandError(const std::string& what, Kind kind) : IoError(what), kind_(kind) {}
  Kind kind() const { return kind_; }
  // Worth retrying later: the link, not the command, failed.
  bool transient() const { return kind_ == Kind::kTimeout || kind_ == Kind::kDisconnected || kind_ == Kind::kOpen; }

 private:
  Kind kind_;
};

struct TextCommandStats {
  std::uint64_t commands = 0;      // sent and (for queries) answered
  std::uint64_t retries = 0;
  std::uint64_t timeouts = 0;
  std::uint64_t reconnects = 0;
  std::uint64_t failures = 0;      // commands that threw after all retries
  std::string last_error;
};

class TextCommandClient {
 public:
  explicit TextCommandClient(TextCommandConfig config);  // connects/opens unless connect_now false
  ~TextCommandClient();
  TextCommandClient(const TextCommandClient&) = delete;
  TextCommandClient& operator=(const TextCommandClient&) = delete;

  // Sends `command` + terminator and returns the next reply line (terminator stripped).
  std::string query(const std::string& command);
  // Sends `command` + terminator; no reply expected.
  void send(const std::string& command);

  std::string where() const;  // "tcp 127.0.0.1:5025" / "serial /dev/ttyUSB0"
  const TextCommandStats& stats() const { return stats_; }
  const TextCommandConfig& config() const { return c_; }

 private:
  std::string transact(const std::string& command, bool want_reply);
  std::string open_link();  // "" on success, else why
  void close_link();
  bool write_all(const std::string& bytes, std::string& why);
  // Reads one line; returns false with `why` and `kind` on time-out / broken link.
  bool read_line(std::string& line, std::string& why, TextCommandError::Kind& kind);

  TextCommandConfig c_;
  int fd_ = -1;
  std::string pending_;  // bytes received after the last complete line
  TextCommandStats stats_;
};

// "{axis}" / "{value}" style templates: every {name} is replaced by vars[name]; an unknown name is
// an std::invalid_argument naming it. "{{" and "}}" are literal braces.
std::string expand_template(const std::string& templ, const std::map<std::string, std::string>& vars);

// Reads a number from a reply with an ECMAScript regular expression: the first capture group (or
// the whole match when the pattern has none). Throws TextCommandError(kParse) quoting the reply.
double parse_number(const std::string& reply, const std::string& pattern, const std::string& what);

}  // namespace stend::transport
