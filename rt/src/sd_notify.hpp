// systemd's notification protocol, spoken directly: datagrams of "KEY=value" lines to the
// socket named by $NOTIFY_SOCKET (a path, or '@' for the abstract namespace). Without the
// variable (not started by systemd) every call is a no-op.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ioct::rt {

class SdNotifier {
 public:
  // Reads $NOTIFY_SOCKET and $WATCHDOG_USEC (honouring $WATCHDOG_PID) once.
  SdNotifier();
  SdNotifier(const SdNotifier&) = delete;
  SdNotifier& operator=(const SdNotifier&) = delete;
  ~SdNotifier();

  bool enabled() const noexcept { return fd_ >= 0; }
  // Sends `state` ("READY=1\nSTATUS=..."); false when not enabled or the send failed.
  bool notify(std::string_view state) const noexcept;
  // The watchdog interval systemd asked for, if any; ping at least twice per interval.
  std::optional<std::uint64_t> watchdog_interval_ns() const noexcept { return watchdog_ns_; }

 private:
  int fd_ = -1;
  std::string address_;  // sun_path bytes (leading NUL for the abstract namespace)
  std::optional<std::uint64_t> watchdog_ns_;
};

}  // namespace ioct::rt
