// The accept/serve loop of the emulators' TCP peers on 127.0.0.1: a listening socket, its accepted
// connections, and the "peer disappears" fault (everything closed for a while, then listening
// again on the same port). Used by emulators/chamber (Watlow F4, MODBUS TCP: one master, the
// newest wins) and emulators/table_text (the ACUTROL-style text table: any number of clients).
//
// Ownership: the server owns the listening fd and every accepted client fd; it closes a client on
// drop(), all of them on a disconnection period and in the destructor. Threading: construct on
// any thread; then wait(), drop() and clients() belong to the one server thread; port() and
// disconnect_for() may be called from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

namespace stend::emu {

struct LoopbackTcpOptions {
  int port = 0;                // 0: an ephemeral port, chosen at the first listen (see port())
  bool newest_only = false;    // true: a new connection closes the previous one (one master)
  int poll_ms = 20;            // [ms] how long one wait() polls for activity
  int down_sleep_ms = 10;      // [ms] one wait() during a disconnection period
  int relisten_sleep_ms = 20;  // [ms] one wait() after a failed attempt to listen again

  // A port 0..65535, a positive poll, no negative sleeps.
  bool IsValid(std::string* error = nullptr) const;
};

class LoopbackTcpServer {
 public:
  // Listens now; throws IoError "<who>: cannot listen on 127.0.0.1:<port>: <errno text>".
  LoopbackTcpServer(const char* who, LoopbackTcpOptions options);
  ~LoopbackTcpServer();
  LoopbackTcpServer(const LoopbackTcpServer&) = delete;
  LoopbackTcpServer& operator=(const LoopbackTcpServer&) = delete;

  int port() const { return port_.load(); }
  // Closes the connections and the listening socket; listens again on the same port after `d`.
  void disconnect_for(std::chrono::milliseconds d);

  struct Events {
    bool listener = false;      // the listening socket was readable (a connection was offered)
    int accepted_fd = -1;       // the connection accepted in this turn, or −1
    std::vector<int> readable;  // clients with data, hang-up or error (polled before the accept)
  };
  // One turn of the serve loop: sleeps through a disconnection period or a failed re-listen and
  // polls otherwise (up to poll_ms); nothing (nullopt) when there is nothing to do.
  std::optional<Events> wait();
  void drop(int fd);  // closes client fd (read 0 bytes or failed) and forgets it
  const std::vector<int>& clients() const { return clients_; }

 private:
  bool listen_now();
  void close_all();

  LoopbackTcpOptions o_;
  std::atomic<int> port_{0};
  int listen_fd_ = -1;
  std::vector<int> clients_;
  std::atomic<std::int64_t> down_until_ns_{0};
};

}  // namespace stend::emu
