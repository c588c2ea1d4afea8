#include "websocket_session.hpp"

#include <algorithm>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "strict_json.hpp"

namespace ioct::view {

namespace beast = boost::beast;
namespace websocket = boost::beast::websocket;

WebSocketSession::WebSocketSession(boost::asio::ip::tcp::socket socket, CountedConnection counted,
                                   Hub& hub, ViewApi& api, const ViewConfig& config)
    : counted_(std::move(counted)), ws_(std::move(socket)), hub_(hub), api_(api), config_(config) {}

WebSocketSession::~WebSocketSession() {
  hub_.leave(this);
  if (own_view_ != 0) api_.close_own_view(own_view_);
}

void WebSocketSession::start(beast::http::request<beast::http::string_body> upgrade) {
  beast::get_lowest_layer(ws_).expires_never();  // the WebSocket keeps its own timeouts
  websocket::stream_base::timeout timeouts{};
  timeouts.handshake_timeout = std::chrono::seconds(10);
  timeouts.idle_timeout = std::chrono::seconds(20);  // a peer silent this long (pings unanswered)
  timeouts.keep_alive_pings = true;
  ws_.set_option(timeouts);
  ws_.read_message_max(config_.max_message_bytes);
  // A frame goes out in one write: fragmented (4 KiB pieces by default), a 100 KB frame took a
  // round of the io loop per piece, interleaved with every other viewer's pieces.
  ws_.auto_fragment(false);
  ws_.async_accept(upgrade, [self = shared_from_this()](beast::error_code ec) {
    if (ec) return;
    self->hub_.join(self);
    self->send_text(std::make_shared<const std::string>(self->hub_.state("viewer").dump()));
    self->read();
  });
}

void WebSocketSession::read() {
  ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    if (ec == websocket::error::message_too_big) {
      return self->refuse_and_close("message larger than " +
                                    std::to_string(self->config_.max_message_bytes) + " bytes");
    }
    if (ec) return;  // closed or broken: the session ends when the last handler lets go
    if (!self->ws_.got_text()) {
      return self->refuse_and_close("binary messages are not accepted");
    }
    std::string text = beast::buffers_to_string(self->buffer_.data());
    self->buffer_.consume(self->buffer_.size());
    if (!self->within_rate()) return self->refuse_and_close("too many messages");
    self->on_message(text);
    if (!self->closing_) self->read();
  });
}

bool WebSocketSession::within_rate() {
  const std::uint64_t now = ioct::monotonic_ns();
  if (tokens_at_ns_ != 0) {
    tokens_ = std::min(2 * kMessagesPerSecond, tokens_ + static_cast<double>(now - tokens_at_ns_) *
                                                             1e-9 * kMessagesPerSecond);
  }
  tokens_at_ns_ = now;
  if (tokens_ < 1.0) return false;
  tokens_ -= 1.0;
  return true;
}

void WebSocketSession::on_message(const std::string& text) {
  nlohmann::json message;
  try {
    message = parse_strict_json(text, config_.max_message_bytes);
  } catch (const BadMessage& e) {
    ++hub_.counters().messages_refused;
    return reply(nullptr, api_error(400, e.what(), e.key()));
  }
  const nlohmann::json id = message.is_object() && message.contains("id") ? message["id"] : nullptr;
  if (!message.is_object() || !message.contains("type") || !message["type"].is_string()) {
    ++hub_.counters().messages_refused;
    return reply(id, api_error(400, "a message is an object with a \"type\" string", "type"));
  }
  // A field of the wrong type is refused like any bad message: nothing a viewer sends may throw
  // out of the io loop, which would end the server for every viewer.
  try {
    dispatch(id, message["type"].get<std::string>(), message);
  } catch (const std::exception& e) {
    ++hub_.counters().messages_refused;
    reply(id, api_error(400, std::string("the message could not be read: ") + e.what()));
  }
}

void WebSocketSession::dispatch(const nlohmann::json& id, const std::string& type,
                                const nlohmann::json& message) {
  const auto need_operator = [&]() {
    if (operator_) return true;
    ++hub_.counters().messages_refused;
    reply(id, api_error(401, "only an operator may do that (send hello with the token first)"));
    return false;
  };
  const auto respond = [self = shared_from_this(), id](ApiReply r) {
    self->reply(id, std::move(r));
  };

  if (type == "hello") {
    if (!message.contains("token") || !message["token"].is_string() ||
        !api_.is_operator_token(message["token"].get<std::string>())) {
      operator_ = false;
      return reply(id, api_error(401, "the operator token is wrong; watching only", "token"));
    }
    operator_ = true;
    reply(id, {200, {{"ok", true}, {"role", "operator"}}});
    send_text(std::make_shared<const std::string>(hub_.state("operator").dump()));
    return;
  }
  if (type == "params") {
    if (!need_operator()) return;
    return api_.set_params(message.value("changes", nlohmann::json()), respond);
  }
  if (type == "scan") {
    if (!need_operator()) return;
    return api_.scan(message, respond);
  }
  if (type == "snapshot") {
    if (!need_operator()) return;
    return api_.snapshot(message, respond);
  }
  if (type == "own_view") {
    // The view is this viewer's from its first message, not from ioct-gpu's reply: a second
    // message before that reply changes the same view instead of opening (and leaking) another.
    const bool open = own_view_ == 0;
    if (open) own_view_ = hub_.new_view_id();
    const std::uint64_t view = own_view_;
    auto self = shared_from_this();
    return api_.set_own_view(view, open, message.value("changes", nlohmann::json::object()),
                             [self, id, view, open](ApiReply r) {
                               if (r.status == 200) {
                                 r.body["view"] = view;
                               } else if (open && self->own_view_ == view) {
                                 self->own_view_ = 0;  // not opened: the shared view again
                               }
                               self->reply(id, std::move(r));
                             });
  }
  if (type == "follow") {
    if (own_view_ != 0) api_.close_own_view(own_view_);
    own_view_ = 0;
    return reply(id, {200, {{"ok", true}, {"view", 0}}});
  }
  if (type == "drawn") {
    if (!message.contains("frame") || !message["frame"].is_number_unsigned()) {
      ++hub_.counters().messages_refused;
      return reply(id, api_error(400, "\"frame\" must be the number of a frame drawn", "frame"));
    }
    const auto frame = message["frame"].get<std::uint64_t>();
    const std::uint64_t now = ioct::monotonic_ns();
    for (const SentFrame& sent : sent_) {
      if (sent.frame_index == frame && sent.t_group_published_ns != 0 &&
          now > sent.t_group_published_ns) {
        if (sent.group_index != last_group_drawn_) {  // the first frame drawn of its group
          hub_.published_to_drawn().record(now - sent.t_group_published_ns);
          last_group_drawn_ = sent.group_index;
        }
        break;
      }
    }
    return;  // no reply: the page reports every frame
  }
  ++hub_.counters().messages_refused;
  reply(id, api_error(400, "unknown message type " + quote_input(type), "type"));
}

void WebSocketSession::reply(const nlohmann::json& id, ApiReply r) {
  nlohmann::json body = std::move(r.body);
  body["type"] = "reply";
  body["id"] = id;
  body["status"] = r.status;
  if (!body.contains("ok")) body["ok"] = r.status == 200;
  if (replies_.size() >= kMaxPendingReplies) {
    return refuse_and_close("not reading its replies");
  }
  replies_.push_back(std::make_shared<const std::string>(body.dump()));
  write_next();
}

void WebSocketSession::send_text(std::shared_ptr<const std::string> text) {
  replies_.push_back(std::move(text));
  write_next();
}

void WebSocketSession::offer_frame(const FrameMessage& frame) {
  if (pending_frame_.bytes) ++hub_.counters().frames_replaced;
  pending_frame_ = frame;
  write_next();
}

void WebSocketSession::drop_own_view(const std::string& reason) {
  if (own_view_ == 0) return;
  api_.close_own_view(own_view_);  // opened on the new connection after all: not left rendering
  own_view_ = 0;
  send_event(std::make_shared<const std::string>(
      nlohmann::json{{"type", "own_view_closed"}, {"reason", reason}}.dump()));
}

void WebSocketSession::send_event(std::shared_ptr<const std::string> event) {
  if (replies_.size() >= kMaxPendingReplies) return refuse_and_close("not reading its messages");
  send_text(std::move(event));
}

void WebSocketSession::offer_state(std::shared_ptr<const std::string> state) {
  pending_state_ = std::move(state);
  write_next();
}

void WebSocketSession::write_next() {
  if (writing_ || closing_) return;
  std::shared_ptr<const std::string> message;
  bool binary = false;
  if (!replies_.empty()) {
    message = std::move(replies_.front());
    replies_.pop_front();
  } else if (pending_state_) {
    message = std::move(pending_state_);
    pending_state_.reset();
  } else if (pending_frame_.bytes) {
    // Its B-scan and tip pair only if this viewer was not sent those very bytes last.
    const bool repeated =
        pending_frame_.without_pictures && pending_frame_.pictures == pictures_sent_;
    message = repeated ? pending_frame_.without_pictures : pending_frame_.bytes;
    pictures_sent_ = pending_frame_.pictures;
    binary = true;
    const std::uint64_t now = ioct::monotonic_ns();
    // The latency of a group is that of the first frame that shows it; the frames after it
    // (a view turning between groups) show the same group, older.
    const bool new_group = !sent_any_ || pending_frame_.group_index != last_group_sent_;
    if (new_group && pending_frame_.t_group_published_ns != 0 &&
        now > pending_frame_.t_group_published_ns) {
      hub_.published_to_sent().record(now - pending_frame_.t_group_published_ns);
    }
    sent_any_ = true;
    last_group_sent_ = pending_frame_.group_index;
    ++hub_.counters().frames_sent;
    sent_[sent_next_++ % sent_.size()] = {pending_frame_.frame_index, pending_frame_.group_index,
                                          pending_frame_.t_group_published_ns};
    pending_frame_ = {};
  } else {
    return;
  }
  writing_ = true;
  ws_.binary(binary);
  ws_.async_write(boost::asio::buffer(*message),
                  [self = shared_from_this(), message](beast::error_code ec, std::size_t) {
                    self->writing_ = false;
                    if (ec) {
                      self->closing_ = true;
                      return;
                    }
                    if (self->closing_) return self->send_close();
                    self->write_next();
                  });
}

void WebSocketSession::refuse_and_close(const std::string& reason) {
  ++hub_.counters().messages_refused;
  if (closing_) return;
  closing_ = true;
  close_reason_ = reason;
  hub_.leave(this);
  if (!writing_) send_close();  // else when the write in flight ends (one write at a time)
}

void WebSocketSession::send_close() {
  beast::get_lowest_layer(ws_).expires_after(std::chrono::seconds(2));
  ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, close_reason_),
                  [self = shared_from_this()](beast::error_code) {});
}

}  // namespace ioct::view
