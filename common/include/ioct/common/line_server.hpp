// A JSON-lines control socket (ioct-rt's control channel, ioct-record's recorder socket): a
// listening Unix stream socket at a path (mode 0660, owned by a configured group, so access is a
// matter of filesystem permissions), and its clients, served without threads from the owner's
// poll(). Every line a client sends is handed to a
// handler whose reply goes back as one line. Garbage, over-long lines, clients that never read
// and clients beyond the limit are answered or dropped; none of it reaches the owner's work.
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
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace ioct {

// Lines longer than this are answered with an error and skipped up to their newline.
inline constexpr std::size_t kMaxControlLineBytes = 4096;

// {"ok": false, "error": message} (+ id, + cmd when known), as one line without the newline.
std::string error_reply(const std::string& message, const nlohmann::json& id = nullptr,
                        std::string_view cmd = {});

// How the server's messages name it and its settings.
struct LineServerNames {
  std::string socket = "control socket";  // "control socket /run/ioct/rt.sock: ..."
  std::string owner = "ioct-rt";          // "in use by a running process (another ...?)"
  std::string group_key = "control.socket_group";
  std::string max_clients_key = "control.max_clients";
};

class LineServer {
 public:
  // Turns one request line into one reply line (no newline in either).
  using Handler = std::function<std::string(const std::string& line)>;

  // Binds `path` (replacing a stale socket; refusing one a live server answers on) with mode
  // 0660 and, when `group` is not empty, that group. Throws std::runtime_error naming the path,
  // the group and the reason.
  LineServer(std::string path, const std::string& group, std::uint32_t max_clients,
             std::uint64_t idle_timeout_ms = 30'000, LineServerNames names = {});
  LineServer(const LineServer&) = delete;
  LineServer& operator=(const LineServer&) = delete;
  // Closes every client and removes the socket file.
  ~LineServer();

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
  LineServerNames names_;
  std::uint32_t max_clients_;
  std::uint64_t idle_timeout_ns_;
  int listen_fd_ = -1;
  std::vector<Client> clients_;
  std::uint64_t requests_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t closed_idle_ = 0;
};

}  // namespace ioct
