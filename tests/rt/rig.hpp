// A complete acquisition on fakes for in-process tests: a ring, the fake digitizer (or another),
// galvo and lines, a pattern, the acquisition loop and the safety supervisor, on a small fast
// geometry (7.2 ms per group). Real-time priority comes from $IOCT_TEST_RT_PRIORITY or the build's
// default; where SCHED_FIFO is refused the suite runs on and judges bounds leniently.
#pragma once

#include <chrono>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "acquisition_loop.hpp"
#include "fake_hal.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/eventually.hpp"
#include "ioct/test_support/not_realtime.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "safety_supervisor.hpp"

namespace ioct::rt::test {

using test_support::kNotRealtimeAllowanceNs;
using test_support::kSanitized;

#ifndef IOCT_TEST_RT_PRIORITY_DEFAULT
#define IOCT_TEST_RT_PRIORITY_DEFAULT 0
#endif

// $IOCT_TEST_RT_PRIORITY, else the build's default (CMake IOCT_TEST_RT_PRIORITY).
inline int test_rt_priority() {
  const char* text = std::getenv("IOCT_TEST_RT_PRIORITY");
  return text == nullptr ? IOCT_TEST_RT_PRIORITY_DEFAULT : std::atoi(text);
}

using test_support::eventually;

// 64 samples, 32 A-scans + 4 flyback, 4 B-scans per group, 8 per volume, 20 kHz.
inline hal::DigitizerConfig small_geometry() {
  hal::DigitizerConfig g;
  g.samples_per_ascan = 64;
  g.ascans_per_bscan = 32;
  g.flyback_sweeps = 4;
  g.bscans_per_group = 4;
  g.ascan_rate_hz = 20'000.0;
  g.timeout_ms = 20;
  return g;
}
inline constexpr std::uint32_t kBscansPerVolume = 8;

inline scan::ScanTiming timing_of(const hal::DigitizerConfig& g, std::uint32_t bscans_per_volume) {
  return {g.ascans_per_bscan, g.flyback_sweeps, bscans_per_volume, g.ascan_rate_hz};
}

inline scan::ScanPattern small_pattern(const hal::DigitizerConfig& g, double extent = 0.8,
                                       scan::ScanKind kind = scan::ScanKind::raster) {
  scan::ScanSpec s;
  s.kind = kind;
  s.extent_x = s.extent_y = extent;
  return scan::build_scan_pattern(s, timing_of(g, kBscansPerVolume), {1e9, 1e15});
}

inline shm::RingConfig ring_config(const std::string& name, const hal::DigitizerConfig& g) {
  shm::RingConfig config;
  config.name = name;
  config.geometry.samples_per_ascan = g.samples_per_ascan;
  config.geometry.ascans_per_bscan = g.ascans_per_bscan;
  config.geometry.bscans_per_group = g.bscans_per_group;
  config.geometry.bscans_per_volume = kBscansPerVolume;
  config.slot_count = 8;
  config.memory_lock = shm::MemoryLock::none;
  return config;
}

inline LoopSettings loop_settings(const hal::DigitizerConfig& g, int priority,
                                  std::uint32_t lead = 0) {
  LoopSettings s;
  s.galvo_lead_samples = lead;
  s.geometry = g;
  s.extra_status = shm::kStatusSimulated;
  s.realtime.fifo_priority = priority;
  s.realtime.lock_memory = false;
  // The fake paces like hardware and returns just after each group's end; on a shared CI box a
  // late wake-up must not count as a miss here (the deadline tests set their own slack).
  s.publish_slack_ns = 20'000'000;
  // After a fault the loop waits this long for the safety thread's park command (emission off
  // first) before it parks on its own; under a sanitizer that thread can be late by far more.
  s.park_wait_ns = kSanitized ? 1'000'000'000 : 20'000'000;
  return s;
}

inline SupervisorSettings supervisor_settings(int loop_priority) {
  SupervisorSettings s;
  s.policy.arming_timeout_ns = 2'000'000'000;
  s.policy.readback_timeout_ns = 10'000'000;
  s.policy.stall_timeout_ns = 500'000'000;
  s.poll_interval_ns = 1'000'000;
  s.watchdog_toggle_interval_ns = 2'000'000;
  s.realtime = {loop_priority > 0 ? std::min(99, loop_priority + 5) : 0, -1, false};
  return s;
}

struct Rig {
  explicit Rig(const char* tag, hal::DigitizerConfig g = small_geometry(),
               std::uint32_t lead_samples = 0)
      : name(tag),
        geometry(g),
        ring(shm::RingWriter::create(ring_config(name.str(), g))),
        digitizer(&log),
        galvo(&log),
        pattern(small_pattern(g)),
        lead(lead_samples) {
    digitizer.prepare(geometry);
    hal::GalvoOutputConfig gc;
    gc.sample_rate_hz = geometry.ascan_rate_hz;
    gc.fifo_capacity = 4096;
    galvo.prepare(gc);
    lines.prepare({});
  }

  // The loop alone (the test commands it), or with the supervisor.
  void start_loop(hal::Digitizer* other = nullptr,
                  std::optional<LoopSettings> settings = std::nullopt) {
    loop = std::make_unique<AcquisitionLoop>(
        ring, other ? *other : digitizer, galvo, &pattern,
        settings.value_or(loop_settings(geometry, priority, lead)));
    loop_outcome = loop->start();
  }
  void start_supervised(SupervisorSettings s) {
    start_loop();
    supervisor = std::make_unique<SafetySupervisor>(lines, *loop, s);
    supervisor_outcome = supervisor->start();
  }
  void start_supervised() { start_supervised(supervisor_settings(priority)); }
  // Timing bounds are judged strictly only with real-time scheduling and without sanitizers.
  bool realtime() const {
    return !kSanitized && priority > 0 && loop_outcome.fifo_error == 0 &&
           supervisor_outcome.fifo_error == 0;
  }
  SafetyState state() const { return supervisor->status().state; }
  bool reaches(SafetyState s, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    return eventually([&] { return state() == s; }, timeout);
  }
  ~Rig() {
    if (supervisor) supervisor->stop();
    if (loop) loop->stop();
  }

  test_support::ScopedShmName name;
  hal::DigitizerConfig geometry;
  shm::RingWriter ring;
  CallLog log;
  FakeDigitizer digitizer;
  FakeGalvo galvo;
  FakeLines lines;
  scan::ScanPattern pattern;
  std::uint32_t lead;
  int priority = test_rt_priority();
  std::unique_ptr<AcquisitionLoop> loop;
  std::unique_ptr<SafetySupervisor> supervisor;
  RealtimeOutcome loop_outcome;
  RealtimeOutcome supervisor_outcome;
};

}  // namespace ioct::rt::test
