// The control channel's Unix socket: a listening stream socket at a path (mode 0660, owned by a
// configured group, so access is a matter of filesystem permissions), and its clients, served
// without threads from the housekeeping loop's poll(). Every line a client sends is handed to a
// handler whose reply goes back as one line. Garbage, over-long lines, clients that never read
// and clients beyond the limit are answered or dropped; none of it reaches the acquisition.
//
// Idle clients cannot lock the operator out: a client silent for the idle timeout is closed, and
// when every slot is taken a new connection takes the slot of the client that has been silent
// longest (at least kEvictAfterSilenceMs). The operator is whoever sends commands: a client that
// keeps talking keeps its slot; one that only holds a connection open loses it to a newcomer.
#pragma once

#include <poll.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace ioct::rt {

class ControlServer {
 public:
  // Turns one request line into one reply line (no newline in either).
  using Handler = std::function<std::string(const std::string& line)>;

  // Binds `path` (replacing a stale socket; refusing one a live server answers on) with mode
  // 0660 and, when `group` is not empty, that group. Throws std::runtime_error naming the path,
  // the group and the reason.
  ControlServer(std::string path, const std::string& group, std::uint32_t max_clients,
                std::uint64_t idle_timeout_ms = 30'000);
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;
  // Closes every client and removes the socket file.
  ~ControlServer();

  // Adds the descriptors to wait on; process() takes the same range back after poll().
  void add_poll_fds(std::vector<pollfd>& fds) const;
  void process(const pollfd* fds, std::size_t count, const Handler& handler);

  const std::string& path() const noexcept { return path_; }
  std::size_t clients() const noexcept { return clients_.size(); }
  std::uint64_t requests() const noexcept { return requests_; }
  std::uint64_t rejected() const noexcept { return rejected_; }
  std::uint64_t closed_idle() const noexcept { return closed_idle_; }

  // A full server gives a newcomer the slot of a client silent at least this long.
  static constexpr std::uint64_t kEvictAfterSilenceMs = 1000;

  // Bytes a client may leave unread before it is dropped.
  static constexpr std::size_t kMaxPendingReplyBytes = 256 * 1024;

 private:
  struct Client {
    int fd = -1;
    std::string in;
    std::string out;
    bool discarding = false;          // inside an over-long line: drop bytes up to its newline
    bool closing = false;             // reply pending, then close
    std::uint64_t last_heard_ns = 0;  // connected, or its last complete line
  };
  void accept_clients(std::uint64_t now_ns);
  // Closes (with a last reply) clients silent for the idle timeout; true for each one closed.
  void close_idle(std::uint64_t now_ns, std::vector<bool>& drop);
  // Makes room for a newcomer by closing the longest-silent client; false when all are talking.
  bool evict_silent(std::uint64_t now_ns);
  // False when the client is to be dropped.
  bool read_from(Client& client, const Handler& handler);
  bool write_to(Client& client);

  std::string path_;
  std::uint32_t max_clients_;
  std::uint64_t idle_timeout_ns_;
  int listen_fd_ = -1;
  std::vector<Client> clients_;
  std::uint64_t requests_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t closed_idle_ = 0;
};

}  // namespace ioct::rt
