// The simulated lines: emission driven and read back through the external watchdog, inputs that
// follow the bench (faults, footswitch), timestamped edges, and a digitizer that sees the sample
// only while emission is on.
#include "ioct/sim/simulated_lines.hpp"

#include <gtest/gtest.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"

#include "ioct/sim/simulated_digitizer.hpp"

namespace ioct::sim {
namespace {

using namespace std::chrono_literals;

std::shared_ptr<SimulatedBench> bench_with_watchdog(std::uint32_t timeout_ms) {
  BenchConfig config;
  config.watchdog_timeout_ms = timeout_ms;
  return std::make_shared<SimulatedBench>(config);
}

TEST(SimulatedLines, EmissionIsDrivenAndReadBack) {
  auto bench = bench_with_watchdog(0);
  SimulatedLines lines(bench);
  lines.set_laser_emission(true);
  EXPECT_FALSE(lines.laser_emission()) << "not driven before prepare()";
  lines.prepare(hal::LinesConfig{});
  EXPECT_FALSE(lines.laser_emission()) << "outputs start inactive";
  lines.set_laser_emission(true);
  EXPECT_TRUE(lines.laser_emission());
  lines.set_laser_emission(false);
  EXPECT_FALSE(lines.laser_emission());
  lines.set_laser_emission(true);
  lines.release();
  EXPECT_FALSE(lines.laser_emission()) << "released: emission off";
}

TEST(SimulatedLines, BadWiringIsRefused) {
  SimulatedLines lines(bench_with_watchdog(0));
  hal::LinesConfig config;
  config.footswitch.offset = config.laser_emission.offset;
  EXPECT_THROW(lines.prepare(config), ioct::ConfigError);
  EXPECT_THROW(lines.wait_event(1ms), std::logic_error);
}

TEST(SimulatedLines, TheWatchdogCutsEmissionWhenTheHeartbeatStops) {
  // 400 ms: far longer than this thread is ever preempted between a toggle and the next read.
  auto bench = bench_with_watchdog(400);
  SimulatedLines lines(bench);
  lines.prepare(hal::LinesConfig{});
  lines.set_laser_emission(true);
  EXPECT_FALSE(lines.laser_emission()) << "no heartbeat yet";
  lines.toggle_watchdog();
  EXPECT_TRUE(lines.laser_emission());
  std::this_thread::sleep_for(800ms);
  EXPECT_FALSE(lines.laser_emission()) << "the heartbeat stopped";
  lines.toggle_watchdog();
  EXPECT_TRUE(lines.laser_emission()) << "retriggered";
  bench->faults().set(Fault::laser_not_ready, true);
  EXPECT_FALSE(lines.laser_emission()) << "a laser that is not ready does not emit";
}

TEST(SimulatedLines, InputsFollowTheBenchAndEdgesCarryTheirTime) {
  auto bench = bench_with_watchdog(0);
  SimulatedLines lines(bench);
  lines.prepare(hal::LinesConfig{});
  EXPECT_EQ(lines.read_inputs(), (hal::LineInputs{true, true, true, false}));
  EXPECT_FALSE(lines.wait_event(5ms).has_value()) << "nothing changed";

  const std::uint64_t before = monotonic_ns();
  std::thread presser([&] {
    std::this_thread::sleep_for(20ms);
    bench->set_footswitch(true);
  });
  const std::optional<hal::LineEvent> pressed = lines.wait_event(2s);
  const std::uint64_t after = monotonic_ns();
  presser.join();
  ASSERT_TRUE(pressed.has_value());
  EXPECT_EQ(pressed->line, hal::InputLine::footswitch);
  EXPECT_TRUE(pressed->rising);
  EXPECT_GE(pressed->timestamp_ns, before + 15'000'000);
  EXPECT_LE(pressed->timestamp_ns, after);
  EXPECT_TRUE(lines.read_inputs().footswitch);

  bench->faults().set(Fault::trigger_loss, true);
  bench->faults().set(Fault::k_clock_dropout, true);
  const auto first = lines.wait_event(100ms);
  const auto second = lines.wait_event(100ms);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->line, hal::InputLine::sweep_trigger_present);
  EXPECT_FALSE(first->rising);
  EXPECT_EQ(first->timestamp_ns, bench->faults().changed_ns(Fault::trigger_loss));
  EXPECT_EQ(second->line, hal::InputLine::k_clock_valid);
  EXPECT_FALSE(second->rising);
  EXPECT_EQ(lines.read_inputs(), (hal::LineInputs{true, false, false, true}));
  EXPECT_FALSE(lines.wait_event(1ms).has_value());
}

TEST(SimulatedLines, TheDigitizerSeesTheSampleOnlyWhileEmissionIsOn) {
  auto bench = bench_with_watchdog(0);
  hal::DigitizerConfig geometry;
  geometry.samples_per_ascan = 256;
  geometry.ascans_per_bscan = 16;
  geometry.bscans_per_group = 1;
  SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = 16;
  SimulatedDigitizer digitizer(simulation, bench);
  digitizer.prepare(geometry);
  digitizer.start();
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  const auto swing = [&] {
    digitizer.acquire_group(group, info);
    const auto [low, high] = std::minmax_element(group.begin(), group.end());
    return *high - *low;
  };
  EXPECT_GT(swing(), 200) << "no lines on the bench: emission is taken as on";
  SimulatedLines lines(bench);
  lines.prepare(hal::LinesConfig{});
  EXPECT_LT(swing(), 40) << "lines prepared, emission off: dark";
  lines.set_laser_emission(true);
  EXPECT_GT(swing(), 200);
}

}  // namespace
}  // namespace ioct::sim
