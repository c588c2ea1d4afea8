#include "ioct/view_test/http_client.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

namespace ioct::view_test {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;

}  // namespace

HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body, const std::string& bearer,
                       std::chrono::milliseconds timeout) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  http::request<http::string_body> request{http::string_to_verb(method), target, 11};
  request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  request.set(http::field::connection, "close");
  if (!bearer.empty()) request.set(http::field::authorization, "Bearer " + bearer);
  if (!body.empty()) {
    request.set(http::field::content_type, "application/json");
    request.body() = body;
  }
  request.prepare_payload();

  HttpReply reply;
  beast::flat_buffer buffer;
  http::response<http::string_body> response;
  stream.expires_after(timeout);  // covers connect, write and read (asynchronous operations)
  stream.async_connect(
      asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), port),
      [&](beast::error_code ec) {
        if (ec) {
          reply.problem = "connect: " + ec.message();
          return;
        }
        http::async_write(stream, request, [&](beast::error_code wec, std::size_t) {
          if (wec) {
            reply.problem = "write: " + wec.message();
            return;
          }
          http::async_read(stream, buffer, response, [&](beast::error_code rec, std::size_t) {
            if (rec) {
              reply.problem = "read: " + rec.message();
              return;
            }
            reply.status = static_cast<int>(response.result_int());
            reply.body = response.body();
          });
        });
      });
  io.run();
  return reply;
}

unsigned short free_local_port() {
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor(io,
                                   asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  return acceptor.local_endpoint().port();
}

}  // namespace ioct::view_test
