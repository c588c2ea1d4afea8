#include "ioct/shm/ring_attach.hpp"

#include <charconv>
#include <chrono>
#include <thread>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::shm {

bool attach_worth_retrying(RingErrc code) noexcept {
  return code == RingErrc::not_found || code == RingErrc::not_ready ||
         code == RingErrc::producer_gone;
}

std::optional<RingReader> attach_when_available(const std::string& name,
                                                const ReaderOptions& options,
                                                const AttachWait& wait, double waited_s) {
  const std::uint64_t since = monotonic_ns();
  std::uint64_t next_report = since + wait.report_interval_ns;
  for (;;) {
    try {
      return RingReader::attach(name, options);
    } catch (const RingError& e) {
      if (!attach_worth_retrying(e.code())) throw;
      if (wait.stop != nullptr && wait.stop->load(std::memory_order_relaxed)) return std::nullopt;
      const std::uint64_t now = monotonic_ns();
      if (!wait.unbounded && now >= wait.deadline_ns) {
        char seconds[64];
        const auto end = std::to_chars(seconds, seconds + sizeof seconds, waited_s).ptr;
        throw RingError(e.code(), "ring '" + name + "' not readable after " +
                                      std::string(seconds, end) + " s of waiting: " + e.what());
      }
      if (wait.unbounded && wait.report_interval_ns > 0 && wait.on_waiting && now >= next_report) {
        wait.on_waiting(e.code(), now - since);
        next_report = now + wait.report_interval_ns;
      }
      std::this_thread::sleep_for(std::chrono::nanoseconds(wait.retry_interval_ns));
    }
  }
}

}  // namespace ioct::shm
