#include "view_config.hpp"

#include <boost/asio/ip/address.hpp>

#include "ioct/common/config_error.hpp"
#include "ioct/shm/shm_object.hpp"

namespace ioct::view {

void ViewConfig::validate() const {
  boost::system::error_code ec;
  (void)boost::asio::ip::make_address(listen_address, ec);
  if (ec) {
    throw ConfigError("view.listen", "'" + listen_address + "'", "must be an IPv4 or IPv6 address");
  }
  if (const std::string problem = shm::object_name_problem(frames); !problem.empty()) {
    throw ConfigError("view.frames", "'" + frames + "'", problem);
  }
  require_real_in_range("view.stale_after", stale_after_s, 0.0, 3600.0);
  require_real_in_range("view.stale_after_periods", stale_after_periods, 1.0, 100.0);
  require_integer_in_range("view.max_connections", max_connections, 1, 4096);
  require_integer_in_range("view.max_connections_per_address", max_connections_per_address, 0,
                           4096);
  require_integer_in_range("view.max_message_bytes", max_message_bytes, 1024, 16u << 20);
  require_real_in_range("view.backend_timeout", backend_timeout_s, 0.01, 10.0);
  require_real_in_range("view.snapshot_timeout", snapshot_timeout_s, 0.1, 120.0);
  require_real_in_range("view.rt_status_interval", rt_status_interval_s, 0.05, 60.0);
  if (state_dir.empty()) throw ConfigError("view.state_dir", "''", "must name a folder");
  if (footswitch_action != "none" && footswitch_action != "snapshot" &&
      footswitch_action != "next-mode" && footswitch_action != "toggle-bscan" &&
      footswitch_action != "toggle-stereo") {
    throw ConfigError("view.footswitch", "'" + footswitch_action + "'",
                      "must be none, snapshot, next-mode, toggle-bscan or toggle-stereo");
  }
}

}  // namespace ioct::view
