#include "view_server.hpp"

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <stdexcept>

#include "http_session.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::view {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

ViewServer::ViewServer(ViewConfig config, OperatorToken token)
    : config_(std::move(config)),
      token_(std::move(token)),
      io_(std::make_unique<asio::io_context>()),
      acceptor_(std::in_place, *io_),
      state_timer_(std::in_place, *io_),
      presets_(config_.state_dir),
      files_(config_.www_dir) {
  config_.validate();
  const tcp::endpoint endpoint{asio::ip::make_address(config_.listen_address), config_.port};
  boost::system::error_code ec;
  acceptor_->open(endpoint.protocol(), ec);
  if (!ec) acceptor_->set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_->bind(endpoint, ec);
  if (!ec) acceptor_->listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + config_.listen_address + ":" +
                             std::to_string(config_.port) + ": " + ec.message());
  }
  port_ = acceptor_->local_endpoint().port();
  // On loopback every peer is this machine (the surgeon's display among them): a limit per
  // address would only lower the whole limit. On a network address, one machine gets at most a few.
  per_address_limit_ = static_cast<int>(
      config_.max_connections_per_address != 0 ? config_.max_connections_per_address
      : endpoint.address().is_loopback()
          ? config_.max_connections
          : std::min(ViewConfig::kNetworkConnectionsPerAddress, config_.max_connections));

  const auto deliver = [this](std::function<void()> task) { asio::post(*io_, std::move(task)); };
  backends_ = std::make_unique<Backends>(
      config_, presets_, deliver, [this](const BackendsSnapshot& s) { hub_.on_backends(s); });
  api_ = std::make_unique<ViewApi>(hub_, *backends_, presets_, token_, config_.max_message_bytes);
  if (config_.footswitch_action != "none") {
    hub_.set_footswitch_handler([this] { api_->footswitch(config_.footswitch_action); });
  }
  StalePolicy policy;
  policy.stale_after_s = config_.stale_after_s;
  policy.stale_after_periods = config_.stale_after_periods;
  follower_ = std::make_unique<FrameFollower>(
      config_.frames, policy,
      [this](std::shared_ptr<const shm::Frame> frame) {
        asio::post(
            *io_, [this, frame = std::move(frame)] { hub_.on_frame(frame, ioct::monotonic_ns()); });
      },
      [this](const FollowerSnapshot& snap) {
        asio::post(*io_, [this, snap] { hub_.on_follower(snap); });
      });
}

ViewServer::~ViewServer() {
  // Whoever posts work stops first; then the io context ends, destroying the sessions its pending
  // handlers hold while the hub, the API and the (stopped) backends they use still exist.
  follower_.reset();
  backends_->shutdown();
  acceptor_.reset();
  state_timer_.reset();
  io_.reset();
}

void ViewServer::accept() {
  acceptor_->async_accept([this](boost::system::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) {
      // At a limit, refused: the others keep their share, and one client (a page reloaded in a
      // storm, a misbehaving tool) cannot take the places the surgeon's display needs.
      std::string address = remote_address(socket);
      if (hub_.connections() >= static_cast<int>(config_.max_connections) ||
          hub_.connections_from(address) >= per_address_limit_) {
        ++hub_.counters().connections_refused;
        boost::system::error_code ignored;
        socket.close(ignored);
      } else {
        // Frames go out as soon as they are written, not when the previous segment is acked.
        boost::system::error_code ignored;
        socket.set_option(tcp::no_delay(true), ignored);
        std::make_shared<HttpSession>(std::move(socket),
                                      CountedConnection(hub_, std::move(address)), hub_, *api_,
                                      files_, config_)
            ->start();
      }
    }
    accept();
  });
}

void ViewServer::tick() {
  state_timer_->expires_after(kStateInterval);
  state_timer_->async_wait([this](boost::system::error_code ec) {
    if (ec) return;
    hub_.broadcast_state();
    tick();
  });
}

void ViewServer::run() {
  asio::signal_set signals(*io_, SIGINT, SIGTERM);
  signals.async_wait([this](boost::system::error_code ec, int) {
    if (!ec) stop();
  });
  accept();
  tick();
  io_->run();
}

void ViewServer::stop() {
  asio::post(*io_, [this] {
    boost::system::error_code ignored;
    acceptor_->close(ignored);
    state_timer_->cancel();
    io_->stop();
  });
}

}  // namespace ioct::view
