#include "ioct/sim/fault_injector.hpp"

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::sim {
namespace {

static_assert(std::atomic<std::uint32_t>::is_always_lock_free);
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

constexpr std::array<std::string_view, kFaultCount> kNames{
    "k_clock_dropout",    "digitizer_stall", "usb_disconnect", "galvo_driver_fault",
    "galvo_stream_stall", "trigger_loss",    "slow_consumer",  "laser_not_ready"};

}  // namespace

std::string_view to_string(Fault fault) noexcept {
  const auto index = static_cast<std::size_t>(fault);
  return index < kNames.size() ? kNames[index] : "unknown";
}

std::optional<Fault> parse_fault(std::string_view name) noexcept {
  for (std::size_t i = 0; i < kNames.size(); ++i) {
    if (kNames[i] == name) return static_cast<Fault>(i);
  }
  return std::nullopt;
}

void FaultInjector::set(Fault fault, bool active) noexcept {
  const std::uint32_t previous = active ? mask_.fetch_or(bit(fault), std::memory_order_acq_rel)
                                        : mask_.fetch_and(~bit(fault), std::memory_order_acq_rel);
  if (((previous & bit(fault)) != 0) != active) {
    changed_ns_[static_cast<std::size_t>(fault)].store(ioct::monotonic_ns(),
                                                       std::memory_order_release);
  }
}

bool FaultInjector::active(Fault fault) const noexcept {
  return (mask_.load(std::memory_order_acquire) & bit(fault)) != 0;
}

std::uint64_t FaultInjector::changed_ns(Fault fault) const noexcept {
  return changed_ns_[static_cast<std::size_t>(fault)].load(std::memory_order_acquire);
}

void FaultInjector::inject_missed_sweeps(std::uint32_t sweeps) noexcept {
  missed_sweeps_.fetch_add(sweeps, std::memory_order_acq_rel);
}

std::uint32_t FaultInjector::take_missed_sweeps() noexcept {
  return missed_sweeps_.exchange(0, std::memory_order_acq_rel);
}

void FaultInjector::set_slow_consumer_delay_us(std::uint32_t delay_us) noexcept {
  slow_consumer_delay_us_.store(delay_us, std::memory_order_release);
}

std::uint32_t FaultInjector::slow_consumer_delay_us() const noexcept {
  return slow_consumer_delay_us_.load(std::memory_order_acquire);
}

}  // namespace ioct::sim
