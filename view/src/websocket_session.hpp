// One browser on the WebSocket: sends it the newest frame of the view it watches and the state,
// takes its messages (docs/live-view.md). Writes go out one at a time, replies first, then the
// state, then the frame; a newer frame or state replaces an unsent one, so a viewer that does not
// read costs one frame of memory and never delays anyone. Floods, oversized or malformed
// messages close the connection with a reason.
#pragma once

#include <array>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "hub.hpp"
#include "view_api.hpp"
#include "view_config.hpp"

namespace ioct::view {

class WebSocketSession final : public Viewer,
                               public std::enable_shared_from_this<WebSocketSession> {
 public:
  WebSocketSession(boost::asio::ip::tcp::socket socket, CountedConnection counted, Hub& hub,
                   ViewApi& api, const ViewConfig& config);
  ~WebSocketSession() override;

  void start(boost::beast::http::request<boost::beast::http::string_body> upgrade);

  std::uint64_t watched_view() const override { return own_view_ != 0 ? own_view_ : 0; }
  bool is_operator() const override { return operator_; }
  void offer_frame(const FrameMessage& frame) override;
  void offer_state(std::shared_ptr<const std::string> state) override;
  void send_event(std::shared_ptr<const std::string> event) override;
  void drop_own_view(const std::string& reason) override;

  static constexpr std::size_t kMaxPendingReplies = 32;
  static constexpr double kMessagesPerSecond = 100.0;  // sustained; bursts up to twice that

 private:
  void read();
  void on_message(const std::string& text);
  void dispatch(const nlohmann::json& id, const std::string& type, const nlohmann::json& message);
  void reply(const nlohmann::json& id, ApiReply r);
  void send_text(std::shared_ptr<const std::string> text);
  void write_next();
  void refuse_and_close(const std::string& reason);
  void send_close();
  bool within_rate();

  CountedConnection counted_;  // the HTTP session's, which this one became
  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  boost::beast::flat_buffer buffer_;
  Hub& hub_;
  ViewApi& api_;
  const ViewConfig& config_;
  bool operator_ = false;
  // Non-zero from its first own_view message on, while it orbits its own camera: later changes
  // go to the same view (ioct-gpu takes one connection's requests in order) until a follow or a
  // refused open.
  std::uint64_t own_view_ = 0;
  bool writing_ = false;
  bool closing_ = false;
  std::string close_reason_;
  std::deque<std::shared_ptr<const std::string>> replies_;
  std::shared_ptr<const std::string> pending_state_;
  FrameMessage pending_frame_;
  // Frames sent lately, to match the page's "drawn" reports with their groups (not their bytes).
  struct SentFrame {
    std::uint64_t frame_index = 0;
    std::uint64_t group_index = 0;
    std::uint64_t t_group_published_ns = 0;  // 0: an empty place
  };
  std::array<SentFrame, 16> sent_{};
  std::size_t sent_next_ = 0;
  bool sent_any_ = false;
  std::uint64_t last_group_sent_ = 0;
  std::uint64_t pictures_sent_ = 0;  // the pictures of the last frame sent (0: none yet)
  std::uint64_t last_group_drawn_ = ~0ull;
  double tokens_ = 2 * kMessagesPerSecond;
  std::uint64_t tokens_at_ns_ = 0;
};

}  // namespace ioct::view
