// Small fakes of the hal interfaces for the acquisition and safety tests: a paced digitizer, a
// galvo output and the lines, each with faults a test can inject at run time and the times at
// which things happened (CLOCK_MONOTONIC ns), so a test can assert order and bounds.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "ioct/hal/digitizer.hpp"
#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/lines.hpp"

namespace ioct::rt::test {

// Who was started, stopped or parked, in order, across the fakes.
class CallLog {
 public:
  void add(const char* what);
  std::vector<std::string> calls() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> calls_;
};

// A digitizer paced like hardware: acquire_group() blocks until the group's last sweep has ended
// (sweep n at start + n / rate) and fills every word with the group's number.
class FakeDigitizer final : public hal::Digitizer {
 public:
  explicit FakeDigitizer(CallLog* log = nullptr) : log_(log) {}
  std::string_view backend() const noexcept override { return "fake"; }

  // Faults for the next group: it blocks timeout_ms longer and comes back with kGroupTimeout
  // (stall), or carries these status flags / missed sweeps, or throws.
  std::atomic<bool> stall_next{false};
  std::atomic<std::uint32_t> next_status{0};
  std::atomic<std::uint32_t> next_missed_sweeps{0};
  std::atomic<bool> throw_next{false};
  std::atomic<std::uint32_t> hang_ms{0};  // the next group blocks this much longer (a hung driver)
  std::atomic<bool> fail_start{false};
  // When the last faulty group came back (the moment the fault became observable).
  std::atomic<std::uint64_t> fault_returned_ns{0};
  std::atomic<std::uint64_t> groups{0};
  std::atomic<std::uint64_t> starts{0};

 protected:
  void do_prepare(const hal::DigitizerConfig&) override {}
  void do_start() override;
  void do_stop() noexcept override;
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override;

 private:
  CallLog* log_;
  std::uint64_t start_ns_ = 0;
  std::uint64_t sweep_ = 0;
};

// A DAC that clocks its FIFO out at the sample rate from start(), keeps every sample written
// (up to a bound) for inspection, and faults on demand.
class FakeGalvo final : public hal::GalvoOutput {
 public:
  explicit FakeGalvo(CallLog* log = nullptr, std::size_t keep = 1 << 20);
  std::string_view backend() const noexcept override { return "fake"; }

  void inject_underrun() noexcept { inject_underrun_.store(true); }
  void inject_driver_fault() noexcept { inject_fault_.store(true); }
  std::atomic<bool> fail_start{false};
  // Set when park() last drove the mirrors to rest; cleared by start().
  std::atomic<std::uint64_t> parked_ns{0};
  std::atomic<std::uint64_t> starts{0};
  std::atomic<std::uint64_t> parks{0};
  // Samples written for the last stream (from the prefill before start() on), in order (the first
  // `keep`); read after the loop has stopped.
  std::span<const hal::GalvoSample> written() const noexcept {
    return {storage_.data(), kept_count_};
  }

 protected:
  void do_prepare(const hal::GalvoOutputConfig& config) override;
  void do_start() override;
  std::size_t do_write(std::span<const hal::GalvoSample> samples) noexcept override;
  hal::GalvoStatus do_status() const noexcept override;
  void do_park() noexcept override;

 private:
  std::uint64_t output_now() const noexcept;
  CallLog* log_;
  std::size_t keep_;
  std::vector<hal::GalvoSample> storage_;
  std::size_t kept_count_ = 0;
  std::uint32_t capacity_ = 0;
  double rate_hz_ = 0.0;
  std::uint64_t start_ns_ = 0;
  std::atomic<bool> streaming_{false};
  std::uint64_t written_ = 0;
  bool fresh_ = true;
  std::atomic<bool> inject_underrun_{false};
  std::atomic<bool> inject_fault_{false};
  std::uint64_t underruns_ = 0;
  std::uint32_t faults_ = 0;
};

// The lines: inputs set by the test (an edge wakes wait_event()), the emission line with a
// read-back that can be made to stick, the watchdog heartbeat counted.
class FakeLines final : public hal::Lines {
 public:
  enum class Readback { follows, stuck_on, stuck_off };

  void prepare(const hal::LinesConfig&) override {}
  void release() noexcept override { set_laser_emission(false); }
  void set_laser_emission(bool on) noexcept override;
  bool laser_emission() const noexcept override;
  hal::LineInputs read_inputs() noexcept override;
  void toggle_watchdog() noexcept override { toggles.fetch_add(1); }
  std::optional<hal::LineEvent> wait_event(std::chrono::nanoseconds timeout) override;
  std::string_view backend() const noexcept override { return "fake"; }

  // Test side. Returns the CLOCK_MONOTONIC time of the edge.
  std::uint64_t set_input(hal::InputLine line, bool level);
  // `then` runs once, on the reader's thread, just after the next read_inputs() took its values:
  // lets a test put an event between the supervisor's read of the lines and the rest of its poll.
  void after_next_read(std::function<void()> then);
  bool after_next_read_pending() const;
  std::atomic<Readback> readback{Readback::follows};

  std::atomic<bool> commanded{false};
  std::atomic<std::uint64_t> emission_on_ns{0};   // last off → on
  std::atomic<std::uint64_t> emission_off_ns{0};  // last on → off
  std::atomic<std::uint64_t> toggles{0};
  std::atomic<std::uint64_t> emission_on_count{0};

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  hal::LineInputs inputs_{true, true, true, true};
  std::function<void()> after_next_read_;
  std::vector<hal::LineEvent> pending_;
};

}  // namespace ioct::rt::test
