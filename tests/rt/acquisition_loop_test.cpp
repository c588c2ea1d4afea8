// The acquisition loop in-process, commanded directly (no supervisor): it arms followers before
// the trigger, feeds the DAC ahead with the lead-shifted trajectory, publishes each group once
// its sweeps have ended, switches patterns at a volume boundary, parks on command, neither
// allocates nor faults nor takes a lock in steady state, and posts what goes wrong.
#include "acquisition_loop.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/lock_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"
#include "probed_simulator.hpp"
#include "rig.hpp"
#include "safety_state_machine.hpp"

namespace ioct::rt {
namespace {

using namespace std::chrono_literals;
using test::eventually;
using test::Rig;

// Reads groups until `count` arrived or `timeout`; returns how many.
std::uint64_t read_groups(
    shm::RingReader& reader, std::uint64_t count, std::chrono::milliseconds timeout,
    const std::function<void(const shm::SlotHeader&, std::span<const std::byte>)>& each) {
  std::vector<std::byte> payload(reader.layout().group_payload_bytes);
  shm::SlotHeader header{};
  std::uint64_t got = 0;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (got < count && std::chrono::steady_clock::now() < end) {
    if (reader.read_next(payload, header) == shm::PollStatus::ready) {
      each(header, payload);
      ++got;
    } else {
      std::this_thread::sleep_for(200us);
    }
  }
  return got;
}

// `workers` synthesis threads in the loop's simulator; the reference synthesises inline.
void publishes_the_simulators_groups_in_order(std::uint32_t workers) {
  // 7.2 ms per group: the ring's 8 slots give this reader (which also recomputes every group)
  // 58 ms of slack on a loaded box.
  // With workers, 28.8 ms per group: more threads share the box with this reader.
  hal::DigitizerConfig geometry = test::small_geometry();
  if (workers > 0) geometry.ascan_rate_hz = 5'000.0;
  Rig rig("rt-loop", geometry);
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = test::kBscansPerVolume;
  simulation.seed = 5;
  simulation.workers = workers;
  sim::SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(geometry);
  // The same simulation on the side: what every published group must hold, byte for byte.
  simulation.workers = 0;
  sim::SimulatedDigitizer reference(simulation);
  reference.prepare(geometry);
  reference.start();
  std::vector<std::uint16_t> expected(geometry.samples_per_group());

  shm::RingReader reader = shm::RingReader::attach(rig.name.str(), {.label = "loop-test"});
  rig.start_loop(&digitizer);
  EXPECT_TRUE(rig.loop_outcome.complete() || rig.priority > 0);
  rig.loop->command_run(1);

  std::uint64_t previous_publish_ns = 0;
  std::uint64_t index = 0;
  const std::uint64_t got = read_groups(
      reader, 24, 30s, [&](const shm::SlotHeader& h, std::span<const std::byte> payload) {
        SCOPED_TRACE(testing::Message() << "group " << h.group_index);
        // With workers the box runs more threads than the test's reader can count on (2 slow
        // cores under ThreadSanitizer): there a lapped reader skips groups, and the reference
        // skips them too, so every group read is still compared byte for byte.
        if (workers == 0) {
          EXPECT_EQ(h.group_index, index) << "a reader that keeps up sees every group";
        }
        EXPECT_EQ(h.first_sweep_counter, h.group_index * geometry.sweeps_per_group());
        const GroupTimes times = group_times(rig.loop->clock(), geometry, h.first_sweep_counter);
        EXPECT_EQ(h.t_first_sweep_ns, times.first_sweep_ns);
        EXPECT_EQ(h.t_last_sweep_ns, times.last_sweep_ns);
        EXPECT_GE(h.t_publish_ns, times.complete_ns) << "published before its sweeps ended";
        EXPECT_GE(h.t_publish_ns, previous_publish_ns);
        EXPECT_EQ(h.status_flags, shm::kStatusSimulated)
            << "no laser flag: emission never verified";
        EXPECT_EQ(h.bscan_count, geometry.bscans_per_group);
        EXPECT_EQ(h.scan_generation, 1u);
        EXPECT_EQ(h.bscans[0].bscan_in_volume, (h.group_index % 2) * 4);
        EXPECT_EQ(h.bscans[0].volume_index, h.group_index / 2);
        EXPECT_EQ(h.bscans[0].galvo_start[0],
                  rig.pattern.bscans[h.bscans[0].bscan_in_volume].start.x);
        previous_publish_ns = h.t_publish_ns;
        hal::GroupInfo info;
        do {
          reference.acquire_group(expected, info);
        } while (info.first_sweep_counter < h.first_sweep_counter);
        EXPECT_EQ(std::memcmp(payload.data(), expected.data(), payload.size()), 0)
            << "the slot holds exactly what the digitizer produced";
        index = h.group_index + 1;
      });
  EXPECT_EQ(got, 24u);
  rig.loop->stop();
  const LoopCounters c = rig.loop->counters();
  EXPECT_EQ(c.groups_published, rig.ring.published());
  EXPECT_GE(c.groups_generated, c.groups_published);
  EXPECT_GE(c.generation_ns_total, c.generation_ns_max);
  EXPECT_EQ(c.arms, 1u);
  EXPECT_EQ(c.parks, 1u) << "stop() parks";
  EXPECT_GT(rig.loop->wake_latency().count(), 0u);
  EXPECT_FALSE(rig.loop->failed());
  if (workers == 0) {
    EXPECT_EQ(reader.counters().dropped(), 0u);
  }
  EXPECT_EQ(digitizer.state(), hal::Digitizer::State::prepared);
  EXPECT_EQ(c.simulator_late_groups, digitizer.simulator_late_groups())
      << "every group the simulator flags late is counted, and only those";
}

TEST(AcquisitionLoop, PublishesTheSimulatorsGroupsInOrderOnceTheirSweepsHaveEnded) {
  publishes_the_simulators_groups_in_order(0);
}

TEST(AcquisitionLoop, PublishesTheSameBytesWithTheSimulatorsSynthesisWorkers) {
  publishes_the_simulators_groups_in_order(2);
}

TEST(AcquisitionLoop, ArmsFollowersBeforeTheTriggerAndParksGalvosBeforeStopping) {
  Rig rig("rt-order");
  rig.start_loop();
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().groups_published >= 3; }, 10s));
  const LoopReport running = rig.loop->report();
  EXPECT_TRUE(running.streaming);
  EXPECT_TRUE(running.verified);
  EXPECT_EQ(running.serving_cycle, 1u);
  rig.loop->command_park();
  ASSERT_TRUE(eventually([&] { return !rig.loop->report().streaming; }, 5s));
  EXPECT_FALSE(rig.loop->report().verified);
  const std::vector<std::string> expected = {"galvo.start", "digitizer.start", "galvo.park",
                                             "digitizer.stop"};
  EXPECT_EQ(rig.log.calls(), expected);
  EXPECT_EQ(rig.galvo.state(), hal::GalvoOutput::State::prepared);
  // Armed again with a new cycle: the same order, the digitizer's counter from 0, the volume
  // count continuing.
  const std::uint64_t before = rig.loop->counters().groups_published;
  rig.loop->command_run(2);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().groups_published >= before + 2; }, 10s));
  EXPECT_EQ(rig.loop->report().serving_cycle, 2u);
  EXPECT_EQ(rig.log.calls().size(), 6u);
  EXPECT_EQ(rig.log.calls()[4], "galvo.start");
  EXPECT_EQ(rig.log.calls()[5], "digitizer.start");
  EXPECT_EQ(rig.loop->counters().scan_generation, 2u) << "every arming is a new generation";
}

TEST(AcquisitionLoop, FeedsTheDacAheadWithTheLeadShiftedTrajectory) {
  constexpr std::uint32_t kLead = 5;
  Rig rig("rt-feed", test::small_geometry(), kLead);
  rig.start_loop();
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().groups_published >= 6; }, 10s));
  const LoopCounters c = rig.loop->counters();
  rig.loop->stop();
  const std::span<const hal::GalvoSample> written = rig.galvo.written();
  const std::size_t spv = rig.pattern.trajectory.size();
  ASSERT_GT(written.size(), 2 * spv);
  for (std::size_t n = 0; n < written.size(); ++n) {
    ASSERT_EQ(written[n], rig.pattern.trajectory[(n + kLead) % spv]) << "DAC sample " << n;
  }
  // Fed three groups ahead (capped by the FIFO): the stream never ran low.
  EXPECT_GT(c.dac_fill_min, rig.geometry.sweeps_per_group());
  EXPECT_EQ(c.dac_underruns, 0u);
}

TEST(AcquisitionLoop, AScanChangeTakesEffectAtAVolumeBoundaryAndTheOldPatternComesBack) {
  Rig rig("rt-change");
  const scan::ScanPattern other =
      test::small_pattern(rig.geometry, 0.3, scan::ScanKind::bidirectional);
  shm::RingReader reader = shm::RingReader::attach(rig.name.str(), {.label = "change-test"});
  rig.start_loop();
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().groups_published >= 3; }, 10s));
  ASSERT_TRUE(rig.loop->offer_pattern(&other));

  std::optional<std::uint64_t> first_new;
  std::uint32_t last_generation = 0;
  read_groups(reader, 40, 20s, [&](const shm::SlotHeader& h, std::span<const std::byte>) {
    ASSERT_GE(h.scan_generation, last_generation) << "generations never go back";
    last_generation = h.scan_generation;
    if (h.scan_generation == 2 && !first_new) {
      first_new = h.group_index;
      EXPECT_EQ(h.bscans[0].bscan_in_volume, 0u) << "starts a volume";
      EXPECT_NE(h.bscans[0].flags & shm::kBscanVolumeStart, 0u);
    }
    const scan::ScanPattern& p = h.scan_generation == 2 ? other : rig.pattern;
    EXPECT_EQ(h.scan_pattern_id, p.pattern_id());
    for (std::uint32_t b = 0; b < h.bscan_count; ++b) {
      const std::uint32_t line = h.bscans[b].bscan_in_volume;
      EXPECT_EQ(h.bscans[b].galvo_start[0], p.bscans[line].start.x);
      EXPECT_EQ((h.bscans[b].flags & shm::kBscanReversed) != 0, p.bscans[line].reversed);
    }
  });
  ASSERT_TRUE(first_new.has_value()) << "the new pattern never landed";
  EXPECT_TRUE(eventually([&] { return rig.loop->take_retired() == &rig.pattern; }, 5s))
      << "the replaced pattern is handed back once no group needs it";
  EXPECT_EQ(rig.loop->counters().scan_changes, 1u);
  rig.loop->stop();
  // The DAC got the old trajectory up to the switch and the new one from there.
}

// A backend that notes, each time the loop asks it for a group, how many allocations, page faults
// and lock acquisitions the loop's thread has made so far: the differences cover whole iterations
// of the loop.
class ProbeDigitizer final : public hal::Digitizer {
 public:
  static constexpr std::size_t kProbes = 40;
  test::ThreadCostProbes<kProbes> probes;
  std::atomic<std::size_t> calls{0};
  std::string_view backend() const noexcept override { return "probe"; }

 protected:
  void do_prepare(const hal::DigitizerConfig&) override {}
  void do_start() override { sweep_ = 0; }
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override {
    const std::size_t call = calls.load(std::memory_order_relaxed);
    probes.note(call);
    std::fill(group.begin(), group.end(), static_cast<std::uint16_t>(call));
    info = {};
    info.first_sweep_counter = sweep_;
    sweep_ += config().sweeps_per_group();
    calls.store(call + 1, std::memory_order_release);
  }

 private:
  std::uint64_t sweep_ = 0;
};

TEST(AcquisitionLoop, SteadyStateIterationsNeitherAllocateNorFaultNorLock) {
  Rig rig("rt-steady");
  ProbeDigitizer digitizer;
  digitizer.prepare(rig.geometry);
  rig.start_loop(&digitizer);
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return digitizer.calls.load() >= ProbeDigitizer::kProbes; }, 20s));
  rig.loop->stop();
  // From the second lap over the ring's 8 slots on (the feed, the schedule, the counters and the
  // ring all in their steady state).
  const std::size_t first = 16;
  const std::size_t last = ProbeDigitizer::kProbes - 1;
  const test::ThreadCosts spent = digitizer.probes.between(first, last);
  EXPECT_EQ(spent.allocations, 0u) << test_support::allocation_counting_method();
  EXPECT_EQ(spent.page_faults, 0u);
  if (test_support::locks_are_counted_or_say_why()) {
    EXPECT_EQ(spent.locks, 0u) << test_support::lock_counting_method();
  }
#if !defined(__SANITIZE_THREAD__)
  // The loop's own counter starts after the first lap. ThreadSanitizer maps the shadow of the
  // ring's memory lazily and keeps faulting it in well into the second lap, so under it only the
  // probe window above (which still holds) says the loop is fault-free.
  EXPECT_EQ(rig.loop->counters().page_faults_steady, 0u);
#endif
}

// The simulator with synthesis workers, noting at each group what ProbeDigitizer notes.
using ProbedSimulator = test::ProbedSimulator<40>;

TEST(AcquisitionLoop, WithSimulatorWorkersSteadyStateIterationsNeitherAllocateNorFaultNorLock) {
  const hal::DigitizerConfig geometry = test::small_geometry();
  Rig rig("rt-steady-workers", geometry);
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = test::kBscansPerVolume;
  simulation.workers = 2;
  ProbedSimulator digitizer(simulation);
  digitizer.prepare(geometry);
  rig.start_loop(&digitizer);
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return digitizer.calls.load() >= ProbedSimulator::kProbes; }, 30s));
  rig.loop->stop();
  // Taking the bench's state, handing the B-scans to the workers, waiting for and copying out
  // their group: none of it allocates, faults or takes a lock on the loop's thread.
  const std::size_t first = 16;
  const std::size_t last = ProbedSimulator::kProbes - 1;
  const test::ThreadCosts spent = digitizer.probes.between(first, last);
  EXPECT_EQ(spent.allocations, 0u) << test_support::allocation_counting_method();
  if (test_support::locks_are_counted_or_say_why()) {
    EXPECT_EQ(spent.locks, 0u) << test_support::lock_counting_method();
  }
#if !defined(__SANITIZE_THREAD__)
  // Under ThreadSanitizer the copy out of the workers' buffers faults pages in every group (80
  // in 23 groups seen): the sanitizer's shadow of those buffers, which the workers' writes
  // renew, not memory of ours. There only the allocations are judged.
  EXPECT_EQ(spent.page_faults, 0u);
#endif
  EXPECT_FALSE(rig.loop->failed());
}

TEST(AcquisitionLoop, ALateSimulatorIsCountedApartFromTheLoopsDeadlineMisses) {
  // 10 MHz: each 9.6 us group of 96 sweeps takes one worker far longer than that to
  // synthesise, so every group comes late, flagged by the simulator, never by the loop.
  hal::DigitizerConfig geometry = test::small_geometry();
  geometry.ascan_rate_hz = 10e6;
  geometry.samples_per_ascan = 2048;
  Rig rig("rt-late-sim", geometry);
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = test::kBscansPerVolume;
  simulation.workers = 1;
  sim::SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(geometry);
  rig.start_loop(&digitizer);
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().groups_published >= 10; }, 30s));
  rig.loop->stop();
  const LoopCounters c = rig.loop->counters();
  EXPECT_GE(c.simulator_late_groups, 10u);
  EXPECT_EQ(c.simulator_late_groups, digitizer.simulator_late_groups());
  EXPECT_GT(c.simulator_worst_lateness_ns, 0u);
  EXPECT_EQ(c.deadline_misses + c.simulator_late_groups >= c.groups_generated, true)
      << "each group is late, by the simulator or by the loop";
  EXPECT_EQ(rig.loop->report().faults & kFaultDeadlineMisses, 0u)
      << "a slow simulator is not the loop's fault";
  EXPECT_FALSE(rig.loop->failed());
  // The first late group after on-time ones is announced once, not every group.
  int announced = 0;
  while (const std::optional<LoopEvent> e = rig.loop->take_event()) {
    if (e->kind == LoopEventKind::simulator_behind) ++announced;
  }
  EXPECT_EQ(announced, 1);
}

TEST(AcquisitionLoop, PublishesTroubleWithItsFlagsAndPostsFaults) {
  // 72 ms per group: the ring's 8 slots hold this test's flagged first group for over half a
  // second, however long a loaded machine holds this thread up before it reads.
  hal::DigitizerConfig geometry = test::small_geometry();
  geometry.ascan_rate_hz = 2'000.0;
  Rig rig("rt-trouble", geometry);
  shm::RingReader reader = shm::RingReader::attach(rig.name.str(), {.label = "trouble-test"});
  rig.start_loop();
  rig.digitizer.next_status = hal::kGroupOverrun;  // reported, not a fault
  rig.digitizer.next_missed_sweeps = 3;            // within max_missed_sweeps_per_group
  rig.loop->command_run(1);
  std::uint32_t flags = 0;
  std::uint32_t missed = 0;
  const auto accumulate = [&](const shm::SlotHeader& h, std::span<const std::byte>) {
    flags |= h.status_flags;
    missed += h.missed_sweeps;
  };
  // Read as they come, so that the flagged first group is read before it can be overwritten.
  ASSERT_EQ(read_groups(reader, 4, 10s, accumulate), 4u);
  EXPECT_EQ(rig.loop->report().faults, 0u);
  EXPECT_EQ(rig.loop->counters().missed_sweeps, 3u);

  rig.digitizer.next_status = hal::kGroupClockFault;  // the k-clock went: a fault
  ASSERT_TRUE(eventually([&] { return rig.loop->report().faults != 0; }, 10s));
  EXPECT_EQ(rig.loop->report().faults, kFaultClockLost);
  // Nobody commands the park: the loop parks on its own after park_wait.
  ASSERT_TRUE(eventually([&] { return !rig.loop->report().streaming; }, 5s));
  EXPECT_NE(rig.galvo.parked_ns.load(), 0u);
  read_groups(reader, rig.loop->counters().groups_published - 4, 5s, accumulate);
  EXPECT_EQ(flags, shm::kStatusSimulated | shm::kStatusOverrun | shm::kStatusMissedTriggers |
                       shm::kStatusClockFault)
      << "the clock-fault group was published with its flag: nothing recorded is lost";
  EXPECT_EQ(missed, 3u);

  // An error from the digitizer ends the cycle with its message.
  rig.loop->command_run(2);
  ASSERT_TRUE(eventually([&] { return rig.loop->report().verified; }, 10s));
  rig.digitizer.throw_next = true;
  ASSERT_TRUE(eventually([&] { return rig.loop->failed(); }, 10s));
  EXPECT_NE(rig.loop->failure().find("USB transfer failed"), std::string::npos);
  EXPECT_TRUE(eventually([&] { return rig.loop->report().faults == kFaultAcquisitionFailed; }, 5s));
}

// A digitizer that takes longer than a group lasts: every group misses its deadline.
class SlowDigitizer final : public hal::Digitizer {
 public:
  std::string_view backend() const noexcept override { return "slow"; }

 protected:
  void do_prepare(const hal::DigitizerConfig&) override {}
  void do_start() override { sweep_ = 0; }
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t>, hal::GroupInfo& info) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(15));  // groups last 7.2 ms
    info = {};
    info.first_sweep_counter = sweep_;
    sweep_ += config().sweeps_per_group();
  }

 private:
  std::uint64_t sweep_ = 0;
};

TEST(AcquisitionLoop, WithoutRealTimeSchedulingMissesAreCountedNotFaults) {
  Rig rig("rt-misses-nort");
  SlowDigitizer slow;
  slow.prepare(rig.geometry);
  LoopSettings settings = test::loop_settings(rig.geometry, 0);  // SCHED_OTHER
  settings.publish_slack_ns = 1'000'000;
  rig.start_loop(&slow, settings);
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->counters().deadline_misses >= 8; }, 10s));
  EXPECT_EQ(rig.loop->report().faults, 0u);
  EXPECT_TRUE(rig.loop->report().streaming);
  rig.loop->stop();  // before `slow`, declared after the rig, is destroyed under its thread
}

TEST(AcquisitionLoop, TooManyDeadlineMissesInARowAreAFault) {
  Rig rig("rt-misses");
  SlowDigitizer slow;
  slow.prepare(rig.geometry);
  LoopSettings settings = test::loop_settings(rig.geometry, rig.priority);
  settings.publish_slack_ns = 1'000'000;
  settings.max_consecutive_misses = 3;
  settings.deadline_faults_without_realtime = true;  // whatever scheduling this box grants
  rig.start_loop(&slow, settings);
  rig.loop->command_run(1);
  ASSERT_TRUE(eventually([&] { return rig.loop->report().faults != 0; }, 10s));
  EXPECT_EQ(rig.loop->report().faults, kFaultDeadlineMisses);
  const LoopCounters c = rig.loop->counters();
  EXPECT_EQ(c.deadline_misses, 4u) << "the fourth miss in a row is the fault";
  EXPECT_GT(c.worst_lateness_ns, 5'000'000u);
  rig.loop->stop();  // before `slow`, declared after the rig, is destroyed under its thread
}

}  // namespace
}  // namespace ioct::rt
