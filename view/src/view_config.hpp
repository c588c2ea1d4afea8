// ioct-view's configuration: where it listens, what it reads and whom it talks to. Every key is
// checked by validate(), which names the key and the value.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace ioct::view {

struct ViewConfig {
  std::string listen_address = "127.0.0.1";  // loopback unless configured for the OR network
  std::uint16_t port = 8080;                 // 0: any free port (tests), printed at start
  std::string frames = "ioct-ring.frames";   // the frame ring ioct-gpu writes
  std::filesystem::path view_socket;         // ioct-gpu's view socket; empty: no render control
  std::filesystem::path control_socket;      // ioct-rt's control socket; empty: no scan control
  std::filesystem::path record_socket;  // ioct-record's control socket; empty: no recording metrics
  std::filesystem::path www_dir;        // the pages; empty: beside the executable
  std::filesystem::path token_file;     // the operators' token; empty: made in state_dir
  std::filesystem::path state_dir = "/var/lib/ioct/view";  // presets, last parameters, token
  double stale_after_s = 0.0;        // 0: stale_after_periods measured group periods
  double stale_after_periods = 3.0;  // the default bound: three group periods
  std::uint32_t max_connections = 64;
  // From one remote address (a page opens a few: its WebSocket and its files): at most this many;
  // 0: 16 on a network address, none of its own on loopback (every peer is this machine).
  std::uint32_t max_connections_per_address = 0;
  static constexpr std::uint32_t kNetworkConnectionsPerAddress = 16;  // its 0 on a network address
  std::uint32_t max_message_bytes = 64 * 1024;  // one browser message or HTTP body
  double backend_timeout_s = 0.5;               // a reply from ioct-gpu or ioct-rt
  // A snapshot's reply waits for the shared view's next full-size render: on the CPU renderer
  // that takes seconds.
  double snapshot_timeout_s = 10.0;
  // ioct-rt's status (state, laser, the footswitch presses it counted) is asked for this often.
  double rt_status_interval_s = 0.1;
  // What a footswitch press does: none, snapshot, next-mode, toggle-bscan or toggle-stereo.
  std::string footswitch_action = "snapshot";

  // Throws ConfigError naming the first bad key ("view.port", ...).
  void validate() const;
};

}  // namespace ioct::view
