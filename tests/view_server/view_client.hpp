// A browser stand-in for the server tests: plain HTTP requests and WebSocket viewers, with Beast's
// synchronous client, each call bounded in time.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace ioct::view::testing {

struct HttpResult {
  unsigned status = 0;
  std::string body;
  nlohmann::json json() const { return nlohmann::json::parse(body, nullptr, false); }
};

// One request to 127.0.0.1:port from `from` (another loopback address is another peer).
HttpResult http_request(std::uint16_t port, const std::string& method, const std::string& target,
                        const std::string& body = {}, const std::string& token = {},
                        const std::string& from = "127.0.0.1");

// A decoded frame message.
struct ReceivedFrame {
  nlohmann::json description;
  std::string render;
  std::string bscan;
};

class WsViewer {
 public:
  // Connects to 127.0.0.1:port from `from` (another loopback address is another peer to the
  // server).
  explicit WsViewer(std::uint16_t port, const std::string& from = "127.0.0.1");
  void send(const nlohmann::json& message);
  void send_raw(const std::string& text);
  // The next message within `timeout`: a frame (binary) or a JSON text; nullopt on timeout or
  // close (closed() then says so).
  struct Message {
    bool binary = false;
    nlohmann::json json;  // text messages
    ReceivedFrame frame;  // binary messages
  };
  std::optional<Message> next(std::chrono::milliseconds timeout);
  // The next frame / the next text message of `type`, skipping others.
  std::optional<ReceivedFrame> next_frame(std::chrono::milliseconds timeout);
  std::optional<nlohmann::json> next_text(const std::string& type,
                                          std::chrono::milliseconds timeout);
  bool closed() const noexcept { return closed_; }
  std::string close_reason() const;

 private:
  boost::asio::io_context io_;
  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  boost::beast::flat_buffer buffer_;
  bool closed_ = false;
};

}  // namespace ioct::view::testing
