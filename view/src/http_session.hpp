// One HTTP connection: pages, the JSON API, /metrics, and the upgrade to the WebSocket on /ws.
// Bounded: headers 16 KiB, bodies max_message_bytes, 30 s to send a request (a client that
// trickles bytes is cut off), keep-alive.
#pragma once

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <memory>
#include <optional>

#include "hub.hpp"
#include "static_files.hpp"
#include "view_api.hpp"
#include "view_config.hpp"

namespace ioct::view {

// The peer's address as the connection limits count it ("unknown" when it cannot be read).
std::string remote_address(const boost::asio::ip::tcp::socket& socket);

class HttpSession final : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(boost::asio::ip::tcp::socket socket, CountedConnection counted, Hub& hub,
              ViewApi& api, const StaticFiles& files, const ViewConfig& config);
  ~HttpSession();
  void start();

 private:
  using Response = boost::beast::http::response<boost::beast::http::string_body>;
  void read();
  void on_request();
  void send(Response response);
  Response json_response(const ApiReply& reply) const;

  std::optional<CountedConnection> counted_;  // handed to the WebSocket session on an upgrade
  boost::beast::tcp_stream stream_;
  boost::beast::flat_buffer buffer_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> parser_;
  Hub& hub_;
  ViewApi& api_;
  const StaticFiles& files_;
  const ViewConfig& config_;
  unsigned version_ = 11;
  bool keep_alive_ = false;
};

}  // namespace ioct::view
