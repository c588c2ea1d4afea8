// What the real-time path must not spend, noted from the thread itself at numbered points: its
// heap allocations, page faults and lock acquisitions so far (tests/support's per-thread
// counters). ProbedSimulator notes them at each group the acquisition loop asks the simulator for.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ioct/hal/digitizer.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/lock_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"

namespace ioct::rt::test {

struct ThreadCosts {
  std::uint64_t allocations = 0;
  std::uint64_t page_faults = 0;
  std::uint64_t locks = 0;
};

template <std::size_t kProbes>
class ThreadCostProbes {
 public:
  // On the thread measured: its counters so far as probe `i` (none past kProbes).
  void note(std::size_t i) noexcept {
    if (i >= kProbes) return;
    allocations_[i].store(test_support::thread_allocations(), std::memory_order_relaxed);
    page_faults_[i].store(test_support::thread_page_faults().total(), std::memory_order_relaxed);
    locks_[i].store(test_support::thread_lock_acquisitions(), std::memory_order_relaxed);
  }
  // What the thread spent from probe `first` to probe `last`.
  ThreadCosts between(std::size_t first, std::size_t last) const noexcept {
    const auto spent = [&](const auto& at) {
      return at[last].load(std::memory_order_relaxed) - at[first].load(std::memory_order_relaxed);
    };
    return {spent(allocations_), spent(page_faults_), spent(locks_)};
  }

 private:
  std::array<std::atomic<std::uint64_t>, kProbes> allocations_{};
  std::array<std::atomic<std::uint64_t>, kProbes> page_faults_{};
  std::array<std::atomic<std::uint64_t>, kProbes> locks_{};
};

// Forwards to the simulator and notes, at each group, the acquisition thread's costs so far.
template <std::size_t kProbeCount>
class ProbedSimulator final : public hal::Digitizer {
 public:
  static constexpr std::size_t kProbes = kProbeCount;
  explicit ProbedSimulator(const sim::SimulationConfig& c) : inner_(c) {}
  ThreadCostProbes<kProbes> probes;
  std::atomic<std::size_t> calls{0};
  std::string_view backend() const noexcept override { return "probed simulator"; }

 protected:
  void do_prepare(const hal::DigitizerConfig& c) override { inner_.prepare(c); }
  void do_start() override { inner_.start(); }
  void do_stop() noexcept override { inner_.stop(); }
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override {
    const std::size_t call = calls.load(std::memory_order_relaxed);
    probes.note(call);
    inner_.acquire_group(group, info);
    calls.store(call + 1, std::memory_order_release);
  }

 private:
  sim::SimulatedDigitizer inner_;
};

}  // namespace ioct::rt::test
