#include "fake_hal.hpp"

#include <time.h>

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/test_support/lock_counter.hpp"

namespace ioct::rt::test {
namespace {

void sleep_until_ns(std::uint64_t deadline) {
  const timespec t{static_cast<time_t>(deadline / 1'000'000'000u),
                   static_cast<long>(deadline % 1'000'000'000u)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) != 0) {
  }
}

}  // namespace

void CallLog::add(const char* what) {
  const std::lock_guard lock(mutex_);
  calls_.emplace_back(what);
}

std::vector<std::string> CallLog::calls() const {
  const std::lock_guard lock(mutex_);
  return calls_;
}

void FakeDigitizer::do_start() {
  if (fail_start.load()) throw std::runtime_error("digitizer refused to start");
  if (log_ != nullptr) log_->add("digitizer.start");
  start_ns_ = ioct::monotonic_ns();
  sweep_ = 0;
  starts.fetch_add(1);
}

void FakeDigitizer::do_stop() noexcept {
  if (log_ != nullptr) log_->add("digitizer.stop");
}

void FakeDigitizer::do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  const hal::DigitizerConfig& g = config();
  info = hal::GroupInfo{};
  info.first_sweep_counter = sweep_;
  const std::uint64_t last = sweep_ + g.sweeps_per_group() - g.flyback_sweeps;
  const std::uint64_t complete =
      start_ns_ + static_cast<std::uint64_t>(static_cast<double>(last) * g.sweep_period_ns());
  sleep_until_ns(complete);
  if (const std::uint32_t hang = hang_ms.exchange(0); hang != 0) {
    sleep_until_ns(ioct::monotonic_ns() + std::uint64_t{hang} * 1'000'000);
  }
  if (throw_next.exchange(false)) {
    fault_returned_ns.store(ioct::monotonic_ns());
    throw std::runtime_error("USB transfer failed");
  }
  if (stall_next.exchange(false)) {
    sleep_until_ns(ioct::monotonic_ns() + std::uint64_t{g.timeout_ms} * 1'000'000);
    info.status = hal::kGroupTimeout;
    fault_returned_ns.store(ioct::monotonic_ns());
    return;
  }
  const std::uint64_t n = groups.fetch_add(1);
  std::fill(group.begin(), group.end(), static_cast<std::uint16_t>(n));
  info.status = next_status.exchange(0);
  info.missed_sweeps = next_missed_sweeps.exchange(0);
  sweep_ += g.sweeps_per_group() + info.missed_sweeps;
  if (info.status != 0 || info.missed_sweeps != 0) fault_returned_ns.store(ioct::monotonic_ns());
}

FakeGalvo::FakeGalvo(CallLog* log, std::size_t keep) : log_(log), keep_(keep) {
  // Touched now: keeping samples must not page-fault on the acquisition thread later.
  storage_.assign(keep_, hal::GalvoSample{});
}

void FakeGalvo::do_prepare(const hal::GalvoOutputConfig& config) {
  capacity_ = config.fifo_capacity;
  rate_hz_ = config.sample_rate_hz;
}

void FakeGalvo::do_start() {
  if (fail_start.load()) throw std::runtime_error("galvo driver refused to start");
  if (log_ != nullptr) log_->add("galvo.start");
  start_ns_ = ioct::monotonic_ns();
  underruns_ = 0;
  faults_ = 0;
  parked_ns.store(0);
  streaming_.store(true);
  starts.fetch_add(1);
}

std::uint64_t FakeGalvo::output_now() const noexcept {
  if (!streaming_.load()) return 0;
  const double elapsed = static_cast<double>(ioct::monotonic_ns() - start_ns_) * 1e-9;
  return std::min<std::uint64_t>(written_, static_cast<std::uint64_t>(elapsed * rate_hz_));
}

std::size_t FakeGalvo::do_write(std::span<const hal::GalvoSample> samples) noexcept {
  const std::uint64_t fill = written_ - output_now();
  const std::size_t room = fill >= capacity_ ? 0 : static_cast<std::size_t>(capacity_ - fill);
  const std::size_t n = std::min(room, samples.size());
  if (fresh_) {  // the first write after a park: a new stream (prefill included)
    kept_count_ = 0;
    fresh_ = false;
  }
  for (std::size_t i = 0; i < n && kept_count_ < keep_; ++i) storage_[kept_count_++] = samples[i];
  written_ += n;
  return n;
}

hal::GalvoStatus FakeGalvo::do_status() const noexcept {
  auto* self = const_cast<FakeGalvo*>(this);
  if (self->inject_underrun_.exchange(false)) {
    ++self->underruns_;
    self->faults_ |= hal::kGalvoUnderrun;
  }
  if (self->inject_fault_.exchange(false)) self->faults_ |= hal::kGalvoDriverFault;
  hal::GalvoStatus s;
  s.samples_written = written_;
  s.samples_output = output_now();
  s.fifo_fill = static_cast<std::uint32_t>(s.samples_written - s.samples_output);
  s.underruns = underruns_;
  s.faults = faults_;
  s.parked = !streaming_.load();
  return s;
}

void FakeGalvo::do_park() noexcept {
  if (log_ != nullptr) log_->add("galvo.park");
  streaming_.store(false);
  written_ = 0;
  fresh_ = true;
  parks.fetch_add(1);
  parked_ns.store(ioct::monotonic_ns());
}

void FakeLines::set_laser_emission(bool on) noexcept {
  const bool was = commanded.exchange(on);
  if (was != on) {
    (on ? emission_on_ns : emission_off_ns).store(ioct::monotonic_ns());
    if (on) emission_on_count.fetch_add(1);
  }
}

bool FakeLines::laser_emission() const noexcept {
  switch (readback.load()) {
    case Readback::stuck_on:
      return true;
    case Readback::stuck_off:
      return false;
    case Readback::follows:
      break;
  }
  return commanded.load();
}

hal::LineInputs FakeLines::read_inputs() noexcept {
  hal::LineInputs read;
  std::function<void()> then;
  {
    // This mutex stands in for the GPIO chip's read: a lock of the fake, not of the supervisor.
    const test_support::LocksNotCounted fake_hardware;
    const std::lock_guard lock(mutex_);
    read = inputs_;
    then = std::exchange(after_next_read_, nullptr);
  }
  if (then) then();  // outside the lock: it may set inputs
  return read;
}

void FakeLines::after_next_read(std::function<void()> then) {
  const std::lock_guard lock(mutex_);
  after_next_read_ = std::move(then);
}

bool FakeLines::after_next_read_pending() const {
  const std::lock_guard lock(mutex_);
  return static_cast<bool>(after_next_read_);
}

std::optional<hal::LineEvent> FakeLines::wait_event(std::chrono::nanoseconds timeout) {
  // The wait the real lines make in poll() on their line events, not a lock of the supervisor.
  const test_support::LocksNotCounted fake_hardware;
  std::unique_lock lock(mutex_);
  if (pending_.empty()) changed_.wait_for(lock, timeout, [&] { return !pending_.empty(); });
  if (pending_.empty()) return std::nullopt;
  const hal::LineEvent e = pending_.front();
  pending_.erase(pending_.begin());
  return e;
}

std::uint64_t FakeLines::set_input(hal::InputLine line, bool level) {
  const std::uint64_t now = ioct::monotonic_ns();
  {
    const std::lock_guard lock(mutex_);
    switch (line) {
      case hal::InputLine::laser_ready:
        inputs_.laser_ready = level;
        break;
      case hal::InputLine::sweep_trigger_present:
        inputs_.sweep_trigger_present = level;
        break;
      case hal::InputLine::k_clock_valid:
        inputs_.k_clock_valid = level;
        break;
      case hal::InputLine::footswitch:
        inputs_.footswitch = level;
        break;
    }
    pending_.push_back({line, level, now});
  }
  changed_.notify_all();
  return now;
}

}  // namespace ioct::rt::test
