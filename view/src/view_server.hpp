// ioct-view put together: one io thread serves every connection (so the hub needs no lock), the
// frame follower and the backends' thread hand their news to it. run() returns after stop() or
// SIGINT/SIGTERM.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <cstdint>
#include <memory>
#include <optional>

#include "backends.hpp"
#include "frame_follower.hpp"
#include "hub.hpp"
#include "operator_token.hpp"
#include "preset_store.hpp"
#include "static_files.hpp"
#include "view_api.hpp"
#include "view_config.hpp"

namespace ioct::view {

class ViewServer {
 public:
  // Binds the listening socket (throws std::runtime_error naming the address and the reason).
  ViewServer(ViewConfig config, OperatorToken token);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  std::uint16_t port() const noexcept { return port_; }
  void run();
  void stop();  // from any thread

  static constexpr auto kStateInterval = std::chrono::milliseconds(250);

 private:
  void accept();
  void tick();

  const ViewConfig config_;
  const OperatorToken token_;
  // Pointers so the destructor can end the io context (and the sessions whose handlers it holds)
  // while the hub, the API and the backends they refer to still exist.
  std::unique_ptr<boost::asio::io_context> io_;
  std::optional<boost::asio::ip::tcp::acceptor> acceptor_;
  std::optional<boost::asio::steady_timer> state_timer_;
  std::uint16_t port_ = 0;
  int per_address_limit_ = 0;  // max_connections_per_address as it applies to this listener
  Hub hub_;
  PresetStore presets_;
  StaticFiles files_;
  std::unique_ptr<Backends> backends_;
  std::unique_ptr<ViewApi> api_;
  std::unique_ptr<FrameFollower> follower_;
};

}  // namespace ioct::view
