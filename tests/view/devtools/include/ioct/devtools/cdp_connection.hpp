// One WebSocket connection to Chromium's DevTools protocol (the browser's endpoint or one page's):
// numbered JSON commands, each answered by a reply with the same id; events (messages without
// an id) that arrive meanwhile are kept until someone waits for them. Every operation has a
// deadline, so a hung browser fails a test instead of hanging it.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

namespace ioct::devtools {

// The browser answered a command with an error, or did not answer in time.
class CdpError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class CdpConnection {
 public:
  // Connects to ws://127.0.0.1:<port><path> (path as DevToolsActivePort or Target.* give it).
  CdpConnection(unsigned short port, const std::string& path, std::chrono::milliseconds timeout);
  ~CdpConnection();
  CdpConnection(const CdpConnection&) = delete;
  CdpConnection& operator=(const CdpConnection&) = delete;

  // Sends {"id","method","params"} and returns the reply's "result"; throws CdpError with the
  // browser's message for an "error" reply, or when no reply comes within `timeout`.
  nlohmann::json call(const std::string& method, const nlohmann::json& params,
                      std::chrono::milliseconds timeout);

  // The params of the first event named `method`, received earlier or within `timeout`
  // (consumed); nullopt when none comes.
  std::optional<nlohmann::json> wait_event(const std::string& method,
                                           std::chrono::milliseconds timeout);

  // Every event named `method` received so far (consumed), oldest first.
  std::deque<nlohmann::json> take_events(const std::string& method);

 private:
  struct Socket;
  // The next message received, or nullopt at the deadline. One read is always pending, so a
  // deadline that passes costs nothing: the message arrives for the next caller.
  std::optional<nlohmann::json> next_message(std::chrono::steady_clock::time_point deadline);

  std::unique_ptr<Socket> socket_;
  std::deque<nlohmann::json> events_;
  std::uint64_t next_id_ = 1;
};

}  // namespace ioct::devtools
