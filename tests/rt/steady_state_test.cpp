// The long run: ten seconds at the default rate and geometry (100 kHz, 1376 x 512 (+26) x 16 per
// group, 128 per volume) with the physical simulator, a live reader that must see every group,
// and a second reader, in its own process, that is stalled, killed and restarted meanwhile. The
// acquisition's timing and counters must not notice: no drops for the live reader, no deadline
// misses, no heap allocation, no page fault and no lock on the acquisition thread after start;
// the stalled reader's losses are counted as its drops.
//
// Real-time priority comes from $IOCT_TEST_RT_PRIORITY or the build's default (80). Drops are
// asserted to be zero everywhere. Deadline misses are asserted to be zero on a real-time machine,
// a PREEMPT_RT kernel that granted SCHED_FIFO (as the soak judges them); elsewhere they are
// reported, not judged: a stock kernel grants the priority too, yet on a shared two-core box it
// has woken the thread 2.6 ms late with nothing else under test.
#include <signal.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <thread>
#include <vector>

#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/lock_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"
#include "probed_simulator.hpp"
#include "realtime_setup.hpp"
#include "rig.hpp"

namespace ioct::rt {
namespace {

using namespace std::chrono_literals;
using test::eventually;

using test::kSanitized;

// The simulator, noting at each group the acquisition thread's costs so far.
using ProbedSimulator = test::ProbedSimulator<256>;

TEST(SteadyState, TenSecondsAtTheDefaultRateWhileAReaderIsStalledKilledAndRestarted) {
  if (kSanitized) GTEST_SKIP() << "a timing test: it needs an optimised build without sanitizers";
  const hal::DigitizerConfig geometry;  // the defaults: the first paper's system
  const std::uint32_t bscans_per_volume = 128;
  const test_support::ScopedShmName name("rt-steady-10s");
  shm::RingConfig ring_config;
  ring_config.name = name.str();
  ring_config.geometry = {geometry.samples_per_ascan, geometry.ascans_per_bscan,
                          geometry.bscans_per_group, bscans_per_volume, 2};
  ring_config.slot_count = 8;
  ring_config.memory_lock = shm::MemoryLock::best_effort;
  shm::RingWriter ring = shm::RingWriter::create(ring_config);

  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = bscans_per_volume;
  simulation.scan.extent_x = simulation.scan.extent_y = 0.95f;
  // As ioct-rt runs it: synthesis on worker threads, as many as this host's default.
  simulation.workers = sim::SimulationConfig::default_workers(std::thread::hardware_concurrency());
  const int priority = test::test_rt_priority();
  simulation.worker_priority = priority > 0 ? 1 : 0;
  ProbedSimulator digitizer(simulation);
  digitizer.prepare(geometry);
  test::FakeGalvo galvo(nullptr, 0);
  hal::GalvoOutputConfig galvo_config;
  galvo.prepare(galvo_config);
  test::FakeLines lines;
  const scan::ScanPattern pattern =
      scan::build_scan_pattern(scan::ScanSpec{},
                               {geometry.ascans_per_bscan, geometry.flyback_sweeps,
                                bscans_per_volume, geometry.ascan_rate_hz},
                               scan::GalvoLimits{});

  LoopSettings settings = test::loop_settings(geometry, priority);
  settings.publish_slack_ns = 2'000'000;  // the production default
  settings.realtime.lock_memory = priority > 0;
  // Misses are judged here, by count: a loaded box without real-time scheduling may delay a few
  // groups in a row, and the run must go on so the rest is judged (the fault itself is tested
  // on its own).
  settings.max_consecutive_misses = 1000;
  AcquisitionLoop loop(ring, digitizer, galvo, &pattern, settings);
  const RealtimeOutcome loop_outcome = loop.start();
  SafetySupervisor supervisor(lines, loop, test::supervisor_settings(priority));
  const RealtimeOutcome safety_outcome = supervisor.start();
  const bool realtime =
      priority > 0 && loop_outcome.fifo_error == 0 && safety_outcome.fifo_error == 0;
  const bool judge_deadlines = realtime && kernel_is_preempt_rt();

  // The live reader: every group, copied whole.
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> live_consumed{0};
  shm::ReaderCounters live_counters;
  std::thread live([&] {
    shm::RingReader reader = shm::RingReader::attach(name.str(), {.label = "live"});
    std::vector<std::byte> payload(reader.layout().group_payload_bytes);
    shm::SlotHeader header{};
    while (!done.load()) {
      if (reader.read_next(payload, header) == shm::PollStatus::ready) {
        live_consumed.fetch_add(1);
      } else {
        std::this_thread::sleep_for(1ms);
      }
    }
    live_counters = reader.counters();
  });

  supervisor.request_start();
  ASSERT_TRUE(eventually([&] { return supervisor.status().state == SafetyState::scanning; }, 10s));
  const auto started = std::chrono::steady_clock::now();
  const auto at = [&](std::chrono::milliseconds t) { std::this_thread::sleep_until(started + t); };

  // The other reader, a process: running, stalled (SIGSTOP) for 2 s, continued, killed, restarted.
  const std::string reader_exe = test_support::sibling_executable("rt_test_reader");
  std::optional<test_support::ChildProcess> other(
      test_support::ChildProcess::spawn(reader_exe, {name.str(), "other"}));
  ASSERT_EQ(other->read_line(10s), "attached");
  at(2000ms);
  other->send_signal(SIGSTOP);
  at(4000ms);
  other->send_signal(SIGCONT);
  at(5000ms);
  std::uint64_t stalled_drops = 0;
  for (const shm::ReaderReport& r : ring.readers()) {
    if (r.label == "other") stalled_drops = r.counters.dropped();
  }
  other->kill_and_wait();
  other.reset();
  at(6000ms);
  test_support::ChildProcess restarted =
      test_support::ChildProcess::spawn(reader_exe, {name.str(), "restarted"});
  ASSERT_EQ(restarted.read_line(10s), "attached");
  const std::uint64_t published_at_restart = loop.counters().groups_published;
  at(10000ms);
  std::uint64_t restarted_consumed = 0;
  std::size_t dead = 0;
  for (const shm::ReaderReport& r : ring.readers()) {
    if (r.label == "restarted") restarted_consumed = r.counters.consumed;
    if (!r.alive) ++dead;
  }
  const LoopCounters c = loop.counters();
  const LatencyHistogram wake = loop.wake_latency();
  const SafetyStatus safety = supervisor.status();
  supervisor.request_stop();
  eventually([&] { return supervisor.status().state == SafetyState::idle; }, 5s);
  supervisor.stop();
  loop.stop();
  done = true;
  live.join();
  restarted.kill_and_wait();

  const std::size_t probes =
      std::min<std::size_t>(digitizer.calls.load(), ProbedSimulator::kProbes);
  ASSERT_GT(probes, 20u) << "the acquisition stopped early: " << to_string(safety.state) << ", "
                         << describe_faults(safety.record.faults) << ", " << c.groups_published
                         << " groups, " << c.deadline_misses << " misses, worst "
                         << c.worst_lateness_ns << " ns late, generation max "
                         << c.generation_ns_max << " ns";
  const test::ThreadCosts spent = digitizer.probes.between(16, probes - 1);
  std::printf(
      "[ stats    ] %s: %llu groups in 10 s, deadline misses %llu (worst %.2f ms late), wake "
      "latency mean %.1f us max %.1f us over %llu groups, generation %.1f ms mean %.1f ms max of "
      "86.08 ms, DAC fill min %llu samples, live reader consumed %llu dropped %llu, stalled reader "
      "dropped %llu, restarted reader consumed %llu, acquisition thread: %llu allocations, "
      "%llu page faults and %llu locks after the first two laps (%llu page faults in steady state "
      "counted by "
      "the loop), %u synthesis workers, simulator late groups %llu (worst %.2f ms)\n",
      realtime ? "SCHED_FIFO" : "not real-time",
      static_cast<unsigned long long>(c.groups_published),
      static_cast<unsigned long long>(c.deadline_misses),
      static_cast<double>(c.worst_lateness_ns) * 1e-6, wake.mean_ns() * 1e-3,
      static_cast<double>(wake.max()) * 1e-3, static_cast<unsigned long long>(wake.count()),
      static_cast<double>(c.generation_ns_total) * 1e-6 / static_cast<double>(c.groups_generated),
      static_cast<double>(c.generation_ns_max) * 1e-6,
      static_cast<unsigned long long>(c.dac_fill_min),
      static_cast<unsigned long long>(live_counters.consumed),
      static_cast<unsigned long long>(live_counters.dropped()),
      static_cast<unsigned long long>(stalled_drops),
      static_cast<unsigned long long>(restarted_consumed),
      static_cast<unsigned long long>(spent.allocations),
      static_cast<unsigned long long>(spent.page_faults),
      static_cast<unsigned long long>(spent.locks),
      static_cast<unsigned long long>(c.page_faults_steady), simulation.workers,
      static_cast<unsigned long long>(c.simulator_late_groups),
      static_cast<double>(c.simulator_worst_lateness_ns) * 1e-6);

  EXPECT_EQ(safety.state, SafetyState::scanning) << describe_faults(safety.record.faults);
  EXPECT_EQ(safety.record.faults_total, 0u) << describe_faults(safety.record.faults);
  // The absolute schedule holds (late groups catch up) as long as the box can compute the
  // simulation in time; one too loaded for that (mean generation over the budget, not real-time)
  // cannot be judged on it.
  const double generation_mean_ms =
      static_cast<double>(c.generation_ns_total) * 1e-6 / static_cast<double>(c.groups_generated);
  if (realtime || generation_mean_ms < 0.8 * 86.08) {
    EXPECT_NEAR(static_cast<double>(c.groups_published), 10.0 / 0.08608, 3.0);
    EXPECT_EQ(c.dac_underruns, 0u);
  } else {
    std::printf(
        "[ note     ] the box is too loaded to judge the schedule: the simulation took "
        "%.1f ms per 86.08 ms group\n",
        generation_mean_ms);
  }
  EXPECT_EQ(spent.allocations, 0u) << test_support::allocation_counting_method();
  EXPECT_EQ(spent.page_faults, 0u);
  if (test_support::locks_are_counted_or_say_why()) {
    EXPECT_EQ(spent.locks, 0u) << test_support::lock_counting_method();
  }
  EXPECT_GT(stalled_drops, 0u) << "a reader stalled for 2 s loses groups, counted as its drops";
  EXPECT_GE(restarted_consumed + 2, c.groups_published - published_at_restart)
      << "the restarted reader reads everything from where the ring was when it attached";
  EXPECT_GT(restarted_consumed, 0u);
  EXPECT_GE(dead, 1u) << "the killed reader shows as dead";
  EXPECT_GE(live_counters.consumed + live_counters.dropped(), c.groups_published - 1);
  // Everywhere the schedule must hold (late groups catch up, the count stays on time) and the
  // live reader, with 690 ms of ring behind it, loses nothing.
  EXPECT_EQ(live_counters.dropped(), 0u) << "the live reader keeps up";
  if (judge_deadlines) {
    EXPECT_EQ(c.deadline_misses, 0u);
  } else {
    std::printf(
        "[ note     ] not a real-time machine (%s, %s): %llu deadline misses reported, not "
        "judged; they are judged on a PREEMPT_RT kernel with SCHED_FIFO granted "
        "($IOCT_TEST_RT_PRIORITY, e.g. 80)\n",
        kernel_is_preempt_rt() ? "PREEMPT_RT" : "not PREEMPT_RT",
        realtime ? "SCHED_FIFO granted" : "SCHED_FIFO not granted",
        static_cast<unsigned long long>(c.deadline_misses));
  }
}

}  // namespace
}  // namespace ioct::rt
