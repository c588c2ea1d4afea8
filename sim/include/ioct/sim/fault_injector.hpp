// Faults of the simulated bench, switched at run time from any thread.
//
// Every switch is a lock-free atomic: a test (or an operator's tool) flips it while the
// acquisition thread runs, and the simulated backends pick it up at their next group or call.
// What each fault does, and how it shows in GroupInfo, GalvoStatus and LineInputs, is in
// sim/README.md ("Fault injection").
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string_view>

namespace ioct::sim {

enum class Fault : std::uint32_t {
  k_clock_dropout,     // the source's k-clock is lost: records fall back to time-linear sampling
  digitizer_stall,     // the digitizer delivers no records (firmware hang)
  usb_disconnect,      // the USB device (digitizer and galvo DAC stream) is unplugged
  galvo_driver_fault,  // the galvo servo driver reports a fault and stops driving the mirrors
  galvo_stream_stall,  // the DAC stream accepts no samples: the galvo FIFO runs dry
  trigger_loss,        // the sweep trigger is gone
  slow_consumer,       // the host fetches records too slowly: the on-board buffer overflows
  laser_not_ready,     // the source reports not ready; no light reaches the sample
};
inline constexpr std::size_t kFaultCount = 8;

std::string_view to_string(Fault fault) noexcept;
// "k_clock_dropout" -> Fault::k_clock_dropout; nullopt for an unknown name.
std::optional<Fault> parse_fault(std::string_view name) noexcept;

class FaultInjector {
 public:
  FaultInjector() = default;
  FaultInjector(const FaultInjector&) = delete;
  FaultInjector& operator=(const FaultInjector&) = delete;

  // Switches a fault on or off; records when (CLOCK_MONOTONIC) for the lines' edge timestamps.
  void set(Fault fault, bool active) noexcept;
  bool active(Fault fault) const noexcept;
  // All faults as bits (1 << Fault), one atomic read.
  std::uint32_t active_mask() const noexcept { return mask_.load(std::memory_order_acquire); }
  // CLOCK_MONOTONIC ns of the fault's last switch (0: never switched).
  std::uint64_t changed_ns(Fault fault) const noexcept;

  // One-shot: the next group misses `sweeps` sweep triggers (added to any not yet taken).
  void inject_missed_sweeps(std::uint32_t sweeps) noexcept;
  // Takes the missed sweeps injected so far (the digitizer, once per group).
  std::uint32_t take_missed_sweeps() noexcept;

  // How much longer than the sweeps last the host takes to fetch each group while
  // slow_consumer is on (default 10 ms).
  void set_slow_consumer_delay_us(std::uint32_t delay_us) noexcept;
  std::uint32_t slow_consumer_delay_us() const noexcept;

  static constexpr std::uint32_t bit(Fault fault) noexcept {
    return 1u << static_cast<std::uint32_t>(fault);
  }

 private:
  std::atomic<std::uint32_t> mask_{0};
  std::array<std::atomic<std::uint64_t>, kFaultCount> changed_ns_{};
  std::atomic<std::uint32_t> missed_sweeps_{0};
  std::atomic<std::uint32_t> slow_consumer_delay_us_{10'000};
};

}  // namespace ioct::sim
