#include "http_session.hpp"

#include <boost/beast/websocket.hpp>

#include "websocket_session.hpp"

namespace ioct::view {

namespace beast = boost::beast;
namespace http = boost::beast::http;

std::string remote_address(const boost::asio::ip::tcp::socket& socket) {
  boost::system::error_code ec;
  const auto endpoint = socket.remote_endpoint(ec);
  return ec ? std::string("unknown") : endpoint.address().to_string();
}

HttpSession::HttpSession(boost::asio::ip::tcp::socket socket, CountedConnection counted, Hub& hub,
                         ViewApi& api, const StaticFiles& files, const ViewConfig& config)
    : counted_(std::in_place, std::move(counted)),
      stream_(std::move(socket)),
      hub_(hub),
      api_(api),
      files_(files),
      config_(config) {}

HttpSession::~HttpSession() = default;

void HttpSession::start() {
  read();
}

void HttpSession::read() {
  parser_.emplace();
  parser_->header_limit(16 * 1024);
  parser_->body_limit(config_.max_message_bytes);
  stream_.expires_after(std::chrono::seconds(30));
  http::async_read(
      stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
        if (ec == http::error::body_limit || ec == http::error::header_limit) {
          self->keep_alive_ = false;
          return self->send(self->json_response(
              api_error(413, "request larger than " +
                                 std::to_string(self->config_.max_message_bytes) + " bytes")));
        }
        if (ec) return;  // closed, timed out or garbage: drop the connection
        self->on_request();
      });
}

HttpSession::Response HttpSession::json_response(const ApiReply& reply) const {
  Response response{static_cast<http::status>(reply.status), version_};
  response.set(http::field::content_type, "application/json");
  response.set(http::field::cache_control, "no-store");
  response.keep_alive(keep_alive_);
  response.body() = reply.body.dump() + "\n";
  response.prepare_payload();
  return response;
}

void HttpSession::on_request() {
  http::request<http::string_body> request = parser_->release();
  version_ = request.version();
  keep_alive_ = request.keep_alive();
  const std::string target(request.target());
  const std::string path = target.substr(0, target.find_first_of("?#"));

  if (beast::websocket::is_upgrade(request)) {
    if (path != "/ws") return send(json_response(api_error(404, "the WebSocket is at /ws")));
    stream_.expires_never();
    std::make_shared<WebSocketSession>(stream_.release_socket(), std::move(*counted_), hub_, api_,
                                       config_)
        ->start(std::move(request));
    return;
  }

  const http::verb method = request.method();
  if (path == "/metrics" && method == http::verb::get) {
    Response response{http::status::ok, version_};
    response.set(http::field::content_type, "text/plain; version=0.0.4");
    response.keep_alive(keep_alive_);
    response.body() = api_.metrics();
    response.prepare_payload();
    return send(std::move(response));
  }
  if (path.rfind("/api/", 0) == 0) {
    std::string bearer;
    const auto auth = request[http::field::authorization];
    if (auth.size() > 7 && auth.substr(0, 7) == "Bearer ") bearer = std::string(auth.substr(7));
    api_.http(
        std::string(request.method_string()), path, request.body(), bearer,
        [self = shared_from_this()](ApiReply reply) { self->send(self->json_response(reply)); });
    return;
  }
  if (method != http::verb::get && method != http::verb::head) {
    return send(json_response(api_error(405, "pages are read with GET")));
  }
  const auto file = files_.find(path);
  if (!file) return send(json_response(api_error(404, "no such page")));
  Response response{http::status::ok, version_};
  response.set(http::field::content_type, file->content_type);
  response.set(http::field::cache_control, "no-cache");
  // The pages load nothing from elsewhere, and may not be framed by other sites.
  response.set("Content-Security-Policy",
               "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
               "frame-ancestors 'none'");
  response.set("X-Content-Type-Options", "nosniff");
  response.keep_alive(keep_alive_);
  if (method == http::verb::get) response.body() = file->body;
  response.prepare_payload();
  send(std::move(response));
}

void HttpSession::send(Response response) {
  auto message = std::make_shared<Response>(std::move(response));
  http::async_write(
      stream_, *message, [self = shared_from_this(), message](beast::error_code ec, std::size_t) {
        if (ec) return;
        if (!self->keep_alive_ || message->need_eof()) {
          beast::error_code ignored;
          self->stream_.socket().shutdown(boost::asio::ip::tcp::socket::shutdown_send, ignored);
          return;
        }
        self->read();
      });
}

}  // namespace ioct::view
