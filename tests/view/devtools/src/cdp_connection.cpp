#include "ioct/devtools/cdp_connection.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <string_view>

namespace ioct::devtools {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
using Clock = std::chrono::steady_clock;

// A screenshot of a large page is a few MiB of base64.
constexpr std::size_t kMaxMessageBytes = 64u << 20;

}  // namespace

struct CdpConnection::Socket {
  asio::io_context io;
  beast::websocket::stream<beast::tcp_stream> ws{io};
  beast::flat_buffer buffer;
  std::deque<std::string> inbox;  // messages read, not yet taken
  beast::error_code read_error;   // the connection failed; nothing more will come

  // Runs one operation to completion or to `deadline` (Beast's synchronous calls have none).
  template <class Start>
  void run(Clock::time_point deadline, std::string_view what, Start&& start) {
    bool done = false;
    beast::error_code result;
    start([&](beast::error_code ec, auto&&...) {
      done = true;
      result = ec;
    });
    if (io.stopped()) io.restart();  // it stops whenever it runs out of work
    while (!done && io.run_one_until(deadline) > 0) {
    }
    if (!done) throw CdpError("DevTools: no answer to " + std::string(what) + " in time");
    if (result) throw CdpError("DevTools: " + std::string(what) + ": " + result.message());
  }

  void read_next() {
    ws.async_read(buffer, [this](beast::error_code ec, std::size_t) {
      if (ec) {
        read_error = ec;
        return;
      }
      inbox.push_back(beast::buffers_to_string(buffer.data()));
      buffer.consume(buffer.size());
      read_next();
    });
  }
};

CdpConnection::CdpConnection(unsigned short port, const std::string& path,
                             std::chrono::milliseconds timeout)
    : socket_(std::make_unique<Socket>()) {
  const auto deadline = Clock::now() + timeout;
  const asio::ip::tcp::endpoint endpoint(asio::ip::make_address("127.0.0.1"), port);
  socket_->run(deadline, "connect", [&](auto handler) {
    beast::get_lowest_layer(socket_->ws).async_connect(endpoint, handler);
  });
  socket_->ws.read_message_max(kMaxMessageBytes);
  const std::string host = "127.0.0.1:" + std::to_string(port);
  socket_->run(deadline, "WebSocket handshake",
               [&](auto handler) { socket_->ws.async_handshake(host, path, handler); });
  socket_->ws.text(true);
  socket_->read_next();
}

CdpConnection::~CdpConnection() {
  // Closing the TCP socket is enough: the browser drops the session with it.
  beast::error_code ignored;
  beast::get_lowest_layer(socket_->ws).socket().close(ignored);
}

nlohmann::json CdpConnection::call(const std::string& method, const nlohmann::json& params,
                                   std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  const std::uint64_t id = next_id_++;
  const std::string text =
      nlohmann::json{{"id", id}, {"method", method}, {"params", params}}.dump();
  socket_->run(deadline, method,
               [&](auto handler) { socket_->ws.async_write(asio::buffer(text), handler); });
  for (;;) {
    std::optional<nlohmann::json> message = next_message(deadline);
    if (!message) throw CdpError("DevTools: no reply to " + method + " in time");
    if (!message->contains("id")) {
      events_.push_back(std::move(*message));
      continue;
    }
    if (message->at("id").get<std::uint64_t>() != id) continue;  // a reply nobody waits for
    if (message->contains("error")) {
      throw CdpError("DevTools: " + method + ": " + message->at("error").dump());
    }
    return message->value("result", nlohmann::json::object());
  }
}

std::optional<nlohmann::json> CdpConnection::wait_event(const std::string& method,
                                                        std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  for (auto it = events_.begin(); it != events_.end(); ++it) {
    if (it->value("method", "") == method) {
      nlohmann::json params = it->value("params", nlohmann::json::object());
      events_.erase(it);
      return params;
    }
  }
  for (;;) {
    std::optional<nlohmann::json> message = next_message(deadline);
    if (!message) return std::nullopt;
    if (message->contains("id")) continue;  // a late reply to a command that timed out
    if (message->value("method", "") == method) {
      return message->value("params", nlohmann::json::object());
    }
    events_.push_back(std::move(*message));
  }
}

std::deque<nlohmann::json> CdpConnection::take_events(const std::string& method) {
  // Whatever already arrived counts too.
  while (!socket_->inbox.empty() || socket_->io.poll_one() > 0) {
    if (socket_->inbox.empty()) continue;
    nlohmann::json message = nlohmann::json::parse(socket_->inbox.front());
    socket_->inbox.pop_front();
    if (!message.contains("id")) events_.push_back(std::move(message));
  }
  std::deque<nlohmann::json> taken;
  std::deque<nlohmann::json> kept;
  for (nlohmann::json& event : events_) {
    if (event.value("method", "") == method) {
      taken.push_back(event.value("params", nlohmann::json::object()));
    } else {
      kept.push_back(std::move(event));
    }
  }
  events_ = std::move(kept);
  return taken;
}

std::optional<nlohmann::json> CdpConnection::next_message(Clock::time_point deadline) {
  while (socket_->inbox.empty()) {
    if (socket_->read_error) {
      throw CdpError("DevTools: connection lost: " + socket_->read_error.message());
    }
    if (socket_->io.run_one_until(deadline) == 0) {
      if (Clock::now() >= deadline) return std::nullopt;
      if (socket_->io.stopped()) socket_->io.restart();
    }
  }
  nlohmann::json message = nlohmann::json::parse(socket_->inbox.front());
  socket_->inbox.pop_front();
  return message;
}

}  // namespace ioct::devtools
