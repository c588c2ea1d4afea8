#include "acquisition_loop.hpp"

#include <time.h>

#include <algorithm>
#include <future>
#include <span>
#include <stdexcept>
#include <utility>

#include "ioct/shm/monotonic_clock.hpp"

namespace ioct::rt {
namespace {

// Longest single sleep: bounds how long a stop request waits for the thread.
constexpr std::uint64_t kSleepSliceNs = 50'000'000;

timespec to_timespec(std::uint64_t ns) noexcept {
  return timespec{static_cast<time_t>(ns / 1'000'000'000u), static_cast<long>(ns % 1'000'000'000u)};
}

// The slot payload as the digitizer's 16-bit words; the payload is page aligned.
std::span<std::uint16_t> sample_words(std::span<std::byte> payload) noexcept {
  return {reinterpret_cast<std::uint16_t*>(payload.data()), payload.size() / sizeof(std::uint16_t)};
}

// Single writer: a plain load and store keep the maximum.
void store_max(std::atomic<std::uint64_t>& word, std::uint64_t value) noexcept {
  if (value > word.load(std::memory_order_relaxed)) word.store(value, std::memory_order_relaxed);
}

void add(std::atomic<std::uint64_t>& word, std::uint64_t value) noexcept {
  word.store(word.load(std::memory_order_relaxed) + value, std::memory_order_relaxed);
}

}  // namespace

AcquisitionLoop::AcquisitionLoop(shm::RingWriter& ring, hal::Digitizer& digitizer,
                                 Settings settings)
    : ring_(ring), digitizer_(digitizer), settings_(std::move(settings)) {}

AcquisitionLoop::~AcquisitionLoop() {
  stop();
}

RealtimeOutcome AcquisitionLoop::start() {
  if (thread_.joinable()) throw std::logic_error("acquisition loop: start() twice");
  RealtimeOutcome outcome;
  if (settings_.realtime.lock_memory) outcome.memory_lock_error = lock_process_memory();

  std::promise<RealtimeOutcome> ready;
  std::future<RealtimeOutcome> started = ready.get_future();
  // The thread owns the promise: the shared state outlives its set_value() call.
  thread_ = std::thread([this, ready = std::move(ready), outcome]() mutable {
    make_current_thread_realtime(settings_.realtime, outcome);
    prefault_stack(settings_.stack_prefault_bytes);
    try {
      digitizer_.start();
    } catch (...) {
      ready.set_exception(std::current_exception());
      return;
    }
    clock_ = SweepClock(shm::monotonic_ns(), digitizer_.config().sweep_period_ns());
    ready.set_value(outcome);
    run();
  });
  try {
    return started.get();
  } catch (...) {
    thread_.join();
    throw;
  }
}

void AcquisitionLoop::stop() noexcept {
  stop_requested_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
  digitizer_.stop();
}

LoopCounters AcquisitionLoop::counters() const noexcept {
  const auto get = [](const std::atomic<std::uint64_t>& word) {
    return word.load(std::memory_order_relaxed);
  };
  return {get(counters_.groups_generated),    get(counters_.groups_published),
          get(counters_.deadline_misses),     get(counters_.worst_lateness_ns),
          get(counters_.generation_ns_total), get(counters_.generation_ns_max),
          get(counters_.missed_sweeps)};
}

std::string AcquisitionLoop::failure() const {
  return failed() ? failure_ : std::string();
}

void AcquisitionLoop::run() noexcept {
  try {
    acquire_groups();
  } catch (const std::exception& e) {
    failure_ = e.what();
    failed_.store(true, std::memory_order_release);
  }
}

void AcquisitionLoop::acquire_groups() {
  const hal::DigitizerConfig& geometry = settings_.context.geometry;
  while (!stop_requested_.load(std::memory_order_relaxed)) {
    const shm::RingWriter::Claim claim = ring_.claim();
    const std::uint64_t begin_ns = shm::monotonic_ns();
    hal::GroupInfo info;
    digitizer_.acquire_group(sample_words(claim.payload), info);
    const std::uint64_t generated_ns = shm::monotonic_ns();

    const GroupTimes times = group_times(clock_, geometry, info.first_sweep_counter);
    describe_group(*claim.header, info, times, settings_.context);
    add(counters_.groups_generated, 1);
    add(counters_.generation_ns_total, generated_ns - begin_ns);
    store_max(counters_.generation_ns_max, generated_ns - begin_ns);
    add(counters_.missed_sweeps, info.missed_sweeps);

    // The group is published when its last sweep has ended, not before: a simulated group is
    // ready early and waits; one that was not ready in time is a deadline miss.
    if (generated_ns > times.complete_ns) {
      add(counters_.deadline_misses, 1);
      store_max(counters_.worst_lateness_ns, generated_ns - times.complete_ns);
    } else if (!sleep_until(times.complete_ns)) {
      return;
    }
    ring_.publish(claim);
    add(counters_.groups_published, 1);
  }
}

bool AcquisitionLoop::sleep_until(std::uint64_t deadline_ns) const noexcept {
  for (;;) {
    if (stop_requested_.load(std::memory_order_relaxed)) return false;
    const std::uint64_t now = shm::monotonic_ns();
    if (now >= deadline_ns) return true;
    const timespec wake = to_timespec(std::min(deadline_ns, now + kSleepSliceNs));
    // Absolute: wake-up latency never accumulates from group to group. EINTR just loops.
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
  }
}

}  // namespace ioct::rt
