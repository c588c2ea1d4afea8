// The acquisition loop in-process: it publishes the digitizer's groups in order, each only once
// its last sweep has ended, stops promptly, and reports a digitizer that fails.
#include "acquisition_loop.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "ioct/shm/monotonic_clock.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"

namespace ioct::rt {
namespace {

using namespace std::chrono_literals;

// A small geometry: 256 samples, 4 lines of 64 A-scans (+2 flyback) per group, 8 per volume.
hal::DigitizerConfig small_geometry(double rate_hz) {
  hal::DigitizerConfig geometry;
  geometry.samples_per_ascan = 256;
  geometry.ascans_per_bscan = 64;
  geometry.flyback_sweeps = 2;
  geometry.bscans_per_group = 4;
  geometry.ascan_rate_hz = rate_hz;
  return geometry;
}

sim::SimulationConfig small_simulation() {
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = 64;
  simulation.scan.bscans_per_volume = 8;
  simulation.seed = 5;
  return simulation;
}

shm::RingConfig ring_config(const std::string& name, const hal::DigitizerConfig& geometry) {
  shm::RingConfig config;
  config.name = name;
  config.geometry.samples_per_ascan = geometry.samples_per_ascan;
  config.geometry.ascans_per_bscan = geometry.ascans_per_bscan;
  config.geometry.bscans_per_group = geometry.bscans_per_group;
  config.geometry.bscans_per_volume = 8;
  config.slot_count = 8;
  config.memory_lock = shm::MemoryLock::none;
  return config;
}

AcquisitionLoop::Settings settings_for(const hal::DigitizerConfig& geometry,
                                       const hal::RasterScan& scan) {
  AcquisitionLoop::Settings settings;
  settings.context.geometry = geometry;
  settings.context.scan = scan;
  settings.context.extra_status = shm::kStatusSimulated;
  settings.realtime.fifo_priority = 0;  // tests share the machine
  settings.realtime.lock_memory = false;
  return settings;
}

template <typename Predicate>
bool eventually(Predicate done, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

TEST(AcquisitionLoop, PublishesTheDigitizersGroupsInOrderOnceTheirSweepsHaveEnded) {
  const test_support::ScopedShmName name("rt-loop");
  const hal::DigitizerConfig geometry = small_geometry(100'000.0);  // 2.64 ms per group
  shm::RingWriter ring = shm::RingWriter::create(ring_config(name.str(), geometry));
  sim::SimulatedDigitizer digitizer(small_simulation());
  digitizer.prepare(geometry);
  // The same simulation on the side: what every published group must hold, byte for byte.
  sim::SimulatedDigitizer reference(small_simulation());
  reference.prepare(geometry);
  reference.start();
  std::vector<std::uint16_t> expected(geometry.samples_per_group());
  hal::GroupInfo expected_info;

  shm::RingReader reader = shm::RingReader::attach(name.str(), {.label = "loop-test"});
  AcquisitionLoop loop(ring, digitizer, settings_for(geometry, small_simulation().scan));
  const RealtimeOutcome outcome = loop.start();
  EXPECT_TRUE(outcome.complete());  // nothing was requested, so nothing was refused

  const double period_ns = geometry.sweep_period_ns();
  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  std::uint64_t groups = 0;
  std::uint64_t previous_publish_ns = 0;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (groups < 24 && std::chrono::steady_clock::now() < deadline) {
    const shm::PollStatus status = reader.read_next(payload, header);
    if (status != shm::PollStatus::ready) {
      ASSERT_NE(status, shm::PollStatus::producer_gone);
      std::this_thread::sleep_for(200us);
      continue;
    }
    SCOPED_TRACE(testing::Message() << "group " << header.group_index);
    EXPECT_EQ(header.group_index, groups) << "a reader that keeps up sees every group";
    EXPECT_EQ(header.first_sweep_counter, header.group_index * geometry.sweeps_per_group());
    const GroupTimes times = group_times(loop.clock(), geometry, header.first_sweep_counter);
    EXPECT_EQ(header.t_first_sweep_ns, times.first_sweep_ns);
    EXPECT_EQ(header.t_last_sweep_ns, times.last_sweep_ns);
    EXPECT_GE(header.t_publish_ns, times.complete_ns) << "published before its sweeps ended";
    EXPECT_GE(header.t_publish_ns, previous_publish_ns);
    EXPECT_NEAR(static_cast<double>(times.complete_ns - header.t_last_sweep_ns), period_ns, 1.0);
    EXPECT_EQ(header.status_flags, shm::kStatusSimulated);
    EXPECT_EQ(header.bscan_count, geometry.bscans_per_group);
    EXPECT_EQ(header.bscans[0].bscan_in_volume, (header.group_index % 2) * 4);
    EXPECT_EQ(header.bscans[0].volume_index, header.group_index / 2);
    previous_publish_ns = header.t_publish_ns;

    reference.acquire_group(expected, expected_info);
    ASSERT_EQ(expected_info.first_sweep_counter, header.first_sweep_counter);
    EXPECT_EQ(std::memcmp(payload.data(), expected.data(), payload.size()), 0)
        << "the slot holds exactly what the digitizer produced";
    ++groups;
  }
  EXPECT_EQ(groups, 24u);
  loop.stop();
  const LoopCounters counters = loop.counters();
  EXPECT_GE(counters.groups_published, groups);
  EXPECT_EQ(counters.groups_published, ring.published());
  EXPECT_GE(counters.groups_generated, counters.groups_published);
  EXPECT_GT(counters.generation_ns_total, 0u);
  EXPECT_GE(counters.generation_ns_total, counters.generation_ns_max);
  EXPECT_FALSE(loop.failed());
  EXPECT_EQ(reader.counters().dropped(), 0u);
}

TEST(AcquisitionLoop, StopsPromptlyAndNeverPublishesAGroupBeforeItsSweepsEnd) {
  const test_support::ScopedShmName name("rt-stop");
  const hal::DigitizerConfig geometry = small_geometry(1'000.0);  // 264 ms per group
  shm::RingWriter ring = shm::RingWriter::create(ring_config(name.str(), geometry));
  sim::SimulatedDigitizer digitizer(small_simulation());
  digitizer.prepare(geometry);
  AcquisitionLoop loop(ring, digitizer, settings_for(geometry, small_simulation().scan));
  loop.start();
  ASSERT_TRUE(eventually([&] { return loop.counters().groups_generated == 1; }, 10s));
  const auto asked = std::chrono::steady_clock::now();
  loop.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - asked, 2s);
  EXPECT_EQ(loop.counters().groups_published, 0u);
  EXPECT_EQ(ring.published(), 0u);
  EXPECT_EQ(digitizer.state(), hal::Digitizer::State::prepared);
}

// A backend that notes, each time the loop asks it for a group, how many allocations and page
// faults the loop's thread has made so far: the differences cover whole iterations of the loop.
class ProbeDigitizer final : public hal::Digitizer {
 public:
  static constexpr std::size_t kProbes = 32;
  std::array<std::atomic<std::uint64_t>, kProbes> allocations{};
  std::array<std::atomic<std::uint64_t>, kProbes> page_faults{};
  std::atomic<std::size_t> calls{0};

  std::string_view backend() const noexcept override { return "probe"; }

 protected:
  void do_prepare(const hal::DigitizerConfig&) override {}
  void do_start() override {}
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override {
    const std::size_t call = calls.load(std::memory_order_relaxed);
    if (call < kProbes) {
      allocations[call].store(test_support::thread_allocations(), std::memory_order_relaxed);
      page_faults[call].store(test_support::thread_page_faults().total(),
                              std::memory_order_relaxed);
    }
    std::fill(group.begin(), group.end(), static_cast<std::uint16_t>(call));
    info.first_sweep_counter = call * config().sweeps_per_group();
    calls.store(call + 1, std::memory_order_release);
  }
};

TEST(AcquisitionLoop, SteadyStateIterationsNeitherAllocateNorFault) {
  const test_support::ScopedShmName name("rt-steady");
  const hal::DigitizerConfig geometry = small_geometry(100'000.0);
  shm::RingWriter ring = shm::RingWriter::create(ring_config(name.str(), geometry));
  ProbeDigitizer digitizer;
  digitizer.prepare(geometry);
  AcquisitionLoop loop(ring, digitizer, settings_for(geometry, small_simulation().scan));
  loop.start();
  ASSERT_TRUE(eventually([&] { return digitizer.calls.load() >= ProbeDigitizer::kProbes; }, 20s));
  loop.stop();
  // From the second lap over the ring's 8 slots on.
  const std::size_t first = 16;
  const std::size_t last = ProbeDigitizer::kProbes - 1;
  EXPECT_EQ(digitizer.allocations[last] - digitizer.allocations[first], 0u)
      << test_support::allocation_counting_method();
  EXPECT_EQ(digitizer.page_faults[last] - digitizer.page_faults[first], 0u);
}

// A backend that reports trouble on group 1 and fails on group 3.
class TroubledDigitizer final : public hal::Digitizer {
 public:
  std::string_view backend() const noexcept override { return "troubled"; }

 protected:
  void do_prepare(const hal::DigitizerConfig&) override {}
  void do_start() override { group_ = 0; }
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override {
    if (group_ == 3) throw std::runtime_error("USB transfer timed out");
    std::fill(group.begin(), group.end(), static_cast<std::uint16_t>(group_));
    info.first_sweep_counter = group_ * config().sweeps_per_group() + (group_ >= 1 ? 7 : 0);
    info.missed_sweeps = group_ == 1 ? 7 : 0;
    info.status = group_ == 1 ? hal::kGroupOverrun : 0;
    ++group_;
  }

 private:
  std::uint64_t group_ = 0;
};

TEST(AcquisitionLoop, ReportsDigitizerTroubleInTheHeadersAndStopsOnAFailure) {
  const test_support::ScopedShmName name("rt-fail");
  const hal::DigitizerConfig geometry = small_geometry(100'000.0);
  shm::RingWriter ring = shm::RingWriter::create(ring_config(name.str(), geometry));
  TroubledDigitizer digitizer;
  digitizer.prepare(geometry);
  shm::RingReader reader = shm::RingReader::attach(name.str(), {.label = "fail-test"});
  AcquisitionLoop loop(ring, digitizer, settings_for(geometry, small_simulation().scan));
  loop.start();
  ASSERT_TRUE(eventually([&] { return loop.failed(); }, 10s));
  EXPECT_NE(loop.failure().find("USB transfer timed out"), std::string::npos) << loop.failure();
  EXPECT_EQ(loop.counters().groups_published, 3u);
  EXPECT_EQ(loop.counters().missed_sweeps, 7u);
  loop.stop();

  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  std::uint32_t flags[3] = {};
  for (std::uint64_t g = 0; g < 3; ++g) {
    ASSERT_EQ(reader.read_next(payload, header), shm::PollStatus::ready);
    ASSERT_EQ(header.group_index, g);
    flags[g] = header.status_flags;
    EXPECT_EQ(header.missed_sweeps, g == 1 ? 7u : 0u);
    EXPECT_EQ(static_cast<std::uint16_t>(payload[0]), g);  // little-endian low byte of word 0
  }
  EXPECT_EQ(flags[0], shm::kStatusSimulated);
  EXPECT_EQ(flags[1], shm::kStatusSimulated | shm::kStatusOverrun | shm::kStatusMissedTriggers);
  EXPECT_EQ(flags[2], shm::kStatusSimulated);
  // Lost sweeps move the timestamps with them.
  EXPECT_EQ(header.t_first_sweep_ns,
            loop.clock().sweep_start_ns(2 * geometry.sweeps_per_group() + 7));
}

}  // namespace
}  // namespace ioct::rt
