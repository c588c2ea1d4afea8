#include "view_client.hpp"

#include <boost/beast/http.hpp>

namespace ioct::view::testing {

namespace beast = boost::beast;
namespace http = boost::beast::http;
using tcp = boost::asio::ip::tcp;

HttpResult http_request(std::uint16_t port, const std::string& method, const std::string& target,
                        const std::string& body, const std::string& token,
                        const std::string& from) {
  boost::asio::io_context io;
  beast::tcp_stream stream(io);
  stream.expires_after(std::chrono::seconds(5));
  stream.socket().open(tcp::v4());
  stream.socket().bind(tcp::endpoint(boost::asio::ip::make_address(from), 0));
  stream.connect(tcp::endpoint(boost::asio::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> request{http::string_to_verb(method), target, 11};
  request.set(http::field::host, "127.0.0.1");
  if (!token.empty()) request.set(http::field::authorization, "Bearer " + token);
  if (!body.empty()) {
    request.set(http::field::content_type, "application/json");
    request.body() = body;
  }
  request.prepare_payload();
  http::write(stream, request);
  beast::flat_buffer buffer;
  http::response<http::string_body> response;
  http::read(stream, buffer, response);
  beast::error_code ignored;
  stream.socket().shutdown(tcp::socket::shutdown_both, ignored);
  return {response.result_int(), response.body()};
}

WsViewer::WsViewer(std::uint16_t port, const std::string& from) : ws_(io_) {
  beast::get_lowest_layer(ws_).expires_after(std::chrono::seconds(5));
  tcp::socket& socket = beast::get_lowest_layer(ws_).socket();
  socket.open(tcp::v4());
  socket.bind(tcp::endpoint(boost::asio::ip::make_address(from), 0));
  beast::get_lowest_layer(ws_).connect(
      tcp::endpoint(boost::asio::ip::make_address("127.0.0.1"), port));
  ws_.handshake("127.0.0.1", "/ws");
}

void WsViewer::send(const nlohmann::json& message) {
  send_raw(message.dump());
}

void WsViewer::send_raw(const std::string& text) {
  beast::get_lowest_layer(ws_).expires_after(std::chrono::seconds(5));
  ws_.text(true);
  ws_.write(boost::asio::buffer(text));
}

std::optional<WsViewer::Message> WsViewer::next(std::chrono::milliseconds timeout) {
  if (closed_) return std::nullopt;
  // Beast's timeouts apply to asynchronous operations only: read asynchronously and run the
  // io context for at most `timeout`.
  buffer_.consume(buffer_.size());
  bool done = false;
  beast::error_code ec;
  ws_.async_read(buffer_, [&](beast::error_code e, std::size_t) {
    done = true;
    ec = e;
  });
  io_.restart();
  io_.run_for(timeout);
  if (!done) {
    beast::get_lowest_layer(ws_).cancel();
    io_.restart();
    io_.run();
  }
  if (!done || ec) {
    closed_ = true;  // a cancelled read leaves the stream unusable, so any failure ends it
    return std::nullopt;
  }
  Message m;
  const std::string data = beast::buffers_to_string(buffer_.data());
  if (ws_.got_text()) {
    m.json = nlohmann::json::parse(data, nullptr, false);
    return m;
  }
  m.binary = true;
  if (data.size() < 4) return m;
  const std::uint32_t n = static_cast<std::uint8_t>(data[0]) |
                          static_cast<std::uint8_t>(data[1]) << 8 |
                          static_cast<std::uint8_t>(data[2]) << 16 |
                          static_cast<std::uint32_t>(static_cast<std::uint8_t>(data[3])) << 24;
  m.frame.description = nlohmann::json::parse(data.substr(4, n), nullptr, false);
  const std::size_t render = m.frame.description.value("render_bytes", std::size_t{0});
  m.frame.render = data.substr(4 + n, render);
  m.frame.bscan = data.substr(4 + n + render);
  return m;
}

std::optional<ReceivedFrame> WsViewer::next_frame(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    auto m = next(std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now()));
    if (!m) return std::nullopt;
    if (m->binary) return m->frame;
  }
  return std::nullopt;
}

std::optional<nlohmann::json> WsViewer::next_text(const std::string& type,
                                                  std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    auto m = next(std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now()));
    if (!m) return std::nullopt;
    if (!m->binary && m->json.value("type", "") == type) return m->json;
  }
  return std::nullopt;
}

std::string WsViewer::close_reason() const {
  return std::string(ws_.reason().reason.c_str());
}

}  // namespace ioct::view::testing
