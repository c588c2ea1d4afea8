// The simulator's synthesis workers: any worker count gives the bytes and the truth of the inline
// path, group after group and across a restart; the thread that acquires allocates nothing; a
// simulator too slow for its sweep rate flags its groups late instead of hiding it; the worker
// count is validated.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/test_support/allocation_counter.hpp"

namespace ioct::sim {
namespace {

hal::DigitizerConfig test_geometry() {
  hal::DigitizerConfig geometry;  // 1376 samples, 100 kHz
  geometry.ascans_per_bscan = 64;
  geometry.flyback_sweeps = 4;
  geometry.bscans_per_group = 6;
  return geometry;
}

// A retina with a membrane, forceps that move, open their jaws and tremble, and a needle: every
// per-B-scan input (pose, tool truth) and per-A-scan input (beam, speckle, noise) in play.
SimulationConfig scene(const hal::DigitizerConfig& geometry, std::uint32_t workers) {
  SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = 9;  // not a multiple of the group: volumes wrap mid-group
  simulation.retina.membrane.enabled = true;
  InstrumentConfig forceps;
  forceps.kind = InstrumentKind::forceps;
  forceps.pose = {0.1f, 0.0f, 0.4f, 180.0f, 25.0f, 15.0f};
  forceps.motion.velocity_x = 1.5f;
  forceps.motion.tremor_depth = 0.01f;
  forceps.motion.jaw_cycle_deg = 20.0f;
  forceps.motion.jaw_cycle_hz = 5.0f;
  simulation.instruments.push_back(forceps);
  InstrumentConfig needle;
  needle.kind = InstrumentKind::needle;
  needle.pose = {-0.4f, 0.0f, 0.45f, 0.0f, 20.0f, 0.0f};
  simulation.instruments.push_back(needle);
  simulation.seed = 42;
  simulation.workers = workers;
  return simulation;
}

struct Stream {
  std::vector<std::vector<std::uint16_t>> groups;
  std::vector<GroupTruth> truths;
  std::vector<hal::GroupInfo> infos;
};

Stream acquire(SimulatedDigitizer& digitizer, int groups) {
  Stream s;
  for (int g = 0; g < groups; ++g) {
    std::vector<std::uint16_t> group(digitizer.config().samples_per_group());
    hal::GroupInfo info;
    digitizer.acquire_group(group, info);
    s.groups.push_back(std::move(group));
    s.truths.push_back(digitizer.last_group_truth());
    s.infos.push_back(info);
  }
  return s;
}

void expect_same(const Stream& a, const Stream& b, const char* what) {
  ASSERT_EQ(a.groups.size(), b.groups.size());
  for (std::size_t g = 0; g < a.groups.size(); ++g) {
    EXPECT_TRUE(a.groups[g] == b.groups[g]) << what << ": the bytes of group " << g << " differ";
    EXPECT_TRUE(recording::same_bytes(a.truths[g], b.truths[g]))
        << what << ": the truth of group " << g << " differs";
    EXPECT_EQ(a.infos[g].first_sweep_counter, b.infos[g].first_sweep_counter) << what << g;
    EXPECT_EQ(a.infos[g].status & ~hal::kGroupLate, b.infos[g].status & ~hal::kGroupLate)
        << what << g;
  }
}

TEST(SynthesisWorkers, AnyWorkerCountGivesTheInlineBytesAndTruth) {
  const hal::DigitizerConfig geometry = test_geometry();
  constexpr int kGroups = 5;
  SimulatedDigitizer inline_digitizer(scene(geometry, 0));
  inline_digitizer.prepare(geometry);
  inline_digitizer.start();
  const Stream reference = acquire(inline_digitizer, kGroups);
  // The tools are seen, and consecutive groups differ (fresh noise, moving tools).
  std::size_t tool_records = 0;
  for (const GroupTruth& truth : reference.truths) {
    for (const float px : truth.tool_px) tool_records += std::isfinite(px) ? 1 : 0;
  }
  EXPECT_GT(tool_records, 20u);
  EXPECT_NE(reference.groups[0], reference.groups[1]);

  for (const std::uint32_t workers : {1u, 2u, 5u}) {
    SimulatedDigitizer digitizer(scene(geometry, workers));
    digitizer.prepare(geometry);
    EXPECT_EQ(digitizer.workers(), workers);
    digitizer.start();
    const std::string what = std::to_string(workers) + " workers";
    expect_same(reference, acquire(digitizer, kGroups), what.c_str());
    // A restart replays the stream from the first group, whatever was in flight.
    digitizer.stop();
    digitizer.start();
    Stream again = acquire(digitizer, 2);
    Stream first_two;
    for (int g = 0; g < 2; ++g) {
      first_two.groups.push_back(reference.groups[g]);
      first_two.truths.push_back(reference.truths[g]);
      first_two.infos.push_back(reference.infos[g]);
    }
    expect_same(first_two, again, (what + " after a restart").c_str());
  }
}

TEST(SynthesisWorkers, TheAcquiringThreadAllocatesNothing) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(scene(geometry, 2));
  digitizer.prepare(geometry);
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  const test_support::AllocationCounter counter;
  digitizer.start();
  for (int g = 0; g < 4; ++g) digitizer.acquire_group(group, info);
  digitizer.stop();
  digitizer.start();
  digitizer.acquire_group(group, info);
  digitizer.stop();
  EXPECT_EQ(counter.allocations(), 0u) << test_support::allocation_counting_method();
}

TEST(SynthesisWorkers, ASimulatorSlowerThanItsSweepRateFlagsItsGroupsLate) {
  // 10 MHz: a group's 408 sweeps last 41 us, while one worker needs milliseconds for its 384
  // A-scans: every group is ready only after its last sweep ended.
  hal::DigitizerConfig geometry = test_geometry();
  geometry.ascan_rate_hz = 10e6;
  SimulatedDigitizer digitizer(scene(geometry, 1));
  digitizer.prepare(geometry);
  digitizer.start();
  const Stream late = acquire(digitizer, 3);
  for (std::size_t g = 0; g < late.infos.size(); ++g) {
    EXPECT_NE(late.infos[g].status & hal::kGroupLate, 0u) << "group " << g;
  }
  EXPECT_EQ(digitizer.simulator_late_groups(), 3u);
  // Late but whole: the same bytes as on time.
  SimulatedDigitizer inline_digitizer(scene(geometry, 0));
  inline_digitizer.prepare(geometry);
  inline_digitizer.start();
  expect_same(acquire(inline_digitizer, 3), late, "late groups");
  EXPECT_EQ(inline_digitizer.simulator_late_groups(), 0u) << "inline, nothing is ever late";
}

TEST(SynthesisWorkers, TheBenchStateIsTakenOneGroupAheadOfDelivery) {
  // Like a DMA engine one buffer ahead: a fault shows in the group after the one being taken.
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(scene(geometry, 2));
  digitizer.prepare(geometry);
  digitizer.start();  // group 0's state
  hal::GroupInfo info;
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  digitizer.acquire_group(group, info);  // delivers group 0, takes group 1's state
  EXPECT_EQ(info.status & hal::kGroupClockFault, 0u);
  digitizer.bench().faults().set(Fault::k_clock_dropout, true);
  digitizer.acquire_group(group, info);  // group 1: taken before the dropout
  EXPECT_EQ(info.status & hal::kGroupClockFault, 0u);
  digitizer.acquire_group(group, info);  // group 2: taken during it
  EXPECT_NE(info.status & hal::kGroupClockFault, 0u);
  EXPECT_EQ(info.first_sweep_counter, 2 * geometry.sweeps_per_group());
  digitizer.bench().faults().set(Fault::k_clock_dropout, false);
  digitizer.acquire_group(group, info);  // group 3: taken while it still lasted
  EXPECT_NE(info.status & hal::kGroupClockFault, 0u);
  digitizer.acquire_group(group, info);
  EXPECT_EQ(info.status & hal::kGroupClockFault, 0u);
}

TEST(SynthesisWorkers, TheWorkerCountIsValidated) {
  SimulationConfig simulation;
  simulation.workers = SimulationConfig::kMaxWorkers + 1;
  try {
    simulation.validate();
    FAIL() << "65 workers accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("simulation.workers"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("65"), std::string::npos) << e.what();
  }
  simulation.workers = SimulationConfig::kMaxWorkers;
  EXPECT_NO_THROW(simulation.validate());
  EXPECT_EQ(SimulationConfig::default_workers(0), 1u);
  EXPECT_EQ(SimulationConfig::default_workers(2), 1u);
  EXPECT_EQ(SimulationConfig::default_workers(8), 5u);
  EXPECT_EQ(SimulationConfig::default_workers(16), 8u);
}

}  // namespace
}  // namespace ioct::sim
