// The control channel's Unix socket: a listening stream socket at a path (mode 0660, owned by a
// configured group, so access is a matter of filesystem permissions), and its clients, served
// without threads from the housekeeping loop's poll(). Every line a client sends is handed to a
// handler whose reply goes back as one line. Garbage, over-long lines, clients that never read
// and clients beyond the limit are answered or dropped; none of it reaches the acquisition.
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
  ControlServer(std::string path, const std::string& group, std::uint32_t max_clients);
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

  // Bytes a client may leave unread before it is dropped.
  static constexpr std::size_t kMaxPendingReplyBytes = 256 * 1024;

 private:
  struct Client {
    int fd = -1;
    std::string in;
    std::string out;
    bool discarding = false;  // inside an over-long line: drop bytes up to its newline
    bool closing = false;     // reply pending, then close
  };
  void accept_clients();
  // False when the client is to be dropped.
  bool read_from(Client& client, const Handler& handler);
  bool write_to(Client& client);

  std::string path_;
  std::uint32_t max_clients_;
  int listen_fd_ = -1;
  std::vector<Client> clients_;
  std::uint64_t requests_ = 0;
  std::uint64_t rejected_ = 0;
};

}  // namespace ioct::rt
