// A client of a local JSON-lines service (ioct-rt's control socket, ioct-gpu's view socket): one
// request line out, one reply line back, over a Unix stream socket. Every step is bounded in time,
// so a peer that hangs, dies or never answers costs the caller at most the timeout, never a hang.
// Connects lazily and reconnects after any failure. Not thread-safe: one thread uses it.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ioct {

class LineClient {
 public:
  explicit LineClient(std::string socket_path,
                      std::chrono::milliseconds timeout = std::chrono::milliseconds(500));
  ~LineClient();
  LineClient(const LineClient&) = delete;
  LineClient& operator=(const LineClient&) = delete;

  // Sends `line` (a newline is added) and returns the reply line without its newline, or nullopt
  // with the reason in last_error() (cannot connect, timed out, closed, reply too long).
  std::optional<std::string> request(std::string_view line);
  // The same with a time bound of its own (a request whose reply takes longer, e.g. a snapshot).
  std::optional<std::string> request(std::string_view line, std::chrono::milliseconds timeout);

  const std::string& last_error() const noexcept { return error_; }
  const std::string& path() const noexcept { return path_; }
  bool connected() const noexcept { return fd_ >= 0; }
  // Connections made so far: a peer keeps per-connection state (ioct-gpu's views), which a new
  // connection no longer has.
  std::uint64_t connections() const noexcept { return connections_; }

  static constexpr std::size_t kMaxReplyBytes = 1 << 20;

 private:
  bool connect_now();
  void disconnect(std::string reason);

  std::string path_;
  std::chrono::milliseconds timeout_;
  int fd_ = -1;
  std::uint64_t connections_ = 0;
  std::string pending_;  // bytes after the last reply's newline
  std::string error_;
};

}  // namespace ioct
