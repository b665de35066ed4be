// The text-command table protocol: the device's replies through TextCommandClient's line reader
// (TCP on the loopback; the "device" sends the input and closes), each reply line through
// parse_number with the acutrol dialect's reply expression, and the input as a command template
// through expand_template. Each either returns or throws TextCommandError / std::invalid_argument.
#include <stend/devices/text_command.hpp>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

#include "fuzz_support.hpp"
#include "text_table.hpp"

namespace {

// A listening socket on 127.0.0.1, any port, for the process's life.
struct Listener {
  int fd = -1;
  int port = 0;
  Listener() {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 4) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("fuzz: cannot listen on the loopback");
    port = ntohs(a.sin_port);
  }
};

void read_replies(const std::string& bytes) {
  static const Listener listener;
  static const stend::text_table::Dialect dialect = stend::text_table::preset("acutrol");
  stend::transport::TextCommandConfig c;
  c.host = "127.0.0.1";
  c.port = listener.port;
  c.timeout_ms = 20;
  c.retries = 0;
  stend::transport::TextCommandClient client(c);
  const int device = ::accept(listener.fd, nullptr, nullptr);
  if (device < 0) return;
  const ssize_t w = ::write(device, bytes.data(), bytes.size());
  (void)w;
  ::close(device);
  try {
    for (int i = 0; i < 4; ++i) {
      const std::string reply = client.query("POS? 1");
      try {
        (void)stend::transport::parse_number(reply, dialect.response_regex, "position");
      } catch (const stend::transport::TextCommandError&) {
      }
    }
  } catch (const stend::transport::TextCommandError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  read_replies(text);
  try {
    (void)stend::transport::expand_template(text, {{"axis", "1"}, {"value", "12.5"}});
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
