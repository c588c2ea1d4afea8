// The simulated digitizer: its spectra put the layers where its ground truth says, the same seed
// gives the same bytes, and acquisition allocates nothing.
#include "ioct/sim/simulated_digitizer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "ioct/test_support/allocation_counter.hpp"
#include "spectrum_fft.hpp"

namespace ioct::sim {
namespace {

// The default depth axis (1376 samples, 688 px) with a short raster that still crosses the
// fovea: 9 lines, the middle one through the pit, all in one group.
hal::DigitizerConfig test_geometry() {
  hal::DigitizerConfig geometry;
  geometry.ascans_per_bscan = 96;
  geometry.flyback_sweeps = 4;
  geometry.bscans_per_group = 9;
  return geometry;
}

SimulationConfig test_simulation(const hal::DigitizerConfig& geometry, std::uint64_t seed = 7) {
  SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  simulation.scan.bscans_per_volume = 9;
  simulation.seed = seed;
  return simulation;
}

std::vector<std::uint16_t> acquire(SimulatedDigitizer& digitizer, hal::GroupInfo* info = nullptr) {
  std::vector<std::uint16_t> group(digitizer.config().samples_per_group());
  hal::GroupInfo local;
  digitizer.acquire_group(group, info != nullptr ? *info : local);
  return group;
}

TEST(SimulatedDigitizer, FftOfEachAscanPeaksAtTheGroundTruthIlmAndRpe) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  digitizer.start();
  const std::vector<std::uint16_t> group = acquire(digitizer);

  test::SpectrumFft fft(geometry.samples_per_ascan);
  const std::uint32_t depth_bins = geometry.samples_per_ascan / 2;
  float thinnest = 1e9f;
  float thickest = 0.0f;
  for (std::uint32_t line = 0; line < geometry.bscans_per_group; ++line) {
    for (std::uint32_t ascan = 0; ascan < geometry.ascans_per_bscan; ++ascan) {
      SCOPED_TRACE(testing::Message() << "line " << line << " A-scan " << ascan);
      const std::size_t offset =
          (std::size_t{line} * geometry.ascans_per_bscan + ascan) * geometry.samples_per_ascan;
      const auto magnitude = fft.magnitude(
          std::span<const std::uint16_t>(group).subspan(offset, geometry.samples_per_ascan));
      const LayerTruth truth = digitizer.truth_at(line, ascan);
      ASSERT_FALSE(std::isnan(truth.ilm_px));
      ASSERT_FALSE(std::isnan(truth.rpe_px));
      // Past the DC and fixed-pattern bins, most bins hold only noise.
      const float noise_floor = test::median_magnitude(magnitude, depth_bins / 8, depth_bins);
      for (const float depth : {truth.ilm_px, truth.rpe_px}) {
        const std::uint32_t peak = test::peak_near(magnitude, depth, 3);
        EXPECT_NEAR(static_cast<float>(peak), depth, 1.0f);
        EXPECT_GT(magnitude[peak], 10.0f * noise_floor);
      }
      thinnest = std::min(thinnest, truth.rpe_px - truth.ilm_px);
      thickest = std::max(thickest, truth.rpe_px - truth.ilm_px);
    }
  }
  // The raster crosses the foveal pit: there the retina is about half as thick.
  EXPECT_LT(thinnest, 0.6f * thickest);
}

TEST(SimulatedDigitizer, SameSeedGivesIdenticalBytesAndAnotherSeedDiffers) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer first(test_simulation(geometry, 11));
  SimulatedDigitizer second(test_simulation(geometry, 11));
  SimulatedDigitizer other(test_simulation(geometry, 12));
  for (SimulatedDigitizer* digitizer : {&first, &second, &other}) {
    digitizer->prepare(geometry);
    digitizer->start();
  }
  for (int g = 0; g < 2; ++g) {
    const std::vector<std::uint16_t> a = acquire(first);
    const std::vector<std::uint16_t> b = acquire(second);
    const std::vector<std::uint16_t> c = acquire(other);
    EXPECT_EQ(a, b) << "group " << g;
    const auto differing = std::inner_product(a.begin(), a.end(), c.begin(), std::size_t{0},
                                              std::plus<>(), std::not_equal_to<>());
    EXPECT_GT(differing, a.size() / 2) << "group " << g;
  }
}

TEST(SimulatedDigitizer, RestartingReplaysTheSameStream) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  digitizer.start();
  const std::vector<std::uint16_t> before = acquire(digitizer);
  const std::vector<std::uint16_t> next = acquire(digitizer);
  EXPECT_NE(before, next) << "consecutive groups must carry fresh noise";
  digitizer.stop();
  digitizer.start();
  hal::GroupInfo info;
  EXPECT_EQ(acquire(digitizer, &info), before);
  EXPECT_EQ(info.first_sweep_counter, 0u);
}

TEST(SimulatedDigitizer, SweepCounterAdvancesByEverySweepOfTheGroupFlybackIncluded) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  digitizer.start();
  for (std::uint64_t g = 0; g < 3; ++g) {
    hal::GroupInfo info;
    info.missed_sweeps = 99;
    info.status = ~0u;
    acquire(digitizer, &info);
    EXPECT_EQ(info.first_sweep_counter, g * geometry.bscans_per_group * (96 + 4));
    EXPECT_EQ(info.missed_sweeps, 0u);
    EXPECT_EQ(info.status, 0u);
  }
}

TEST(SimulatedDigitizer, SamplesStayWithinTheAdcRange) {
  hal::DigitizerConfig geometry = test_geometry();
  geometry.bscans_per_group = 2;
  for (const std::uint32_t bits : {12u, 10u}) {
    geometry.sample_bits = bits;
    SimulatedDigitizer digitizer(test_simulation(geometry));
    digitizer.prepare(geometry);
    digitizer.start();
    const std::vector<std::uint16_t> group = acquire(digitizer);
    const auto [low, high] = std::minmax_element(group.begin(), group.end());
    EXPECT_LE(*high, (1u << bits) - 1) << bits << " bits";
    // Balanced detection sits about mid-scale, the signal swings around it.
    EXPECT_LT(*low, 1u << (bits - 1)) << bits << " bits";
    EXPECT_GT(*high, 1u << (bits - 1)) << bits << " bits";
  }
}

TEST(SimulatedDigitizer, AcquiringAGroupAllocatesNothing) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  const test_support::AllocationCounter counter;
  digitizer.start();
  for (int g = 0; g < 3; ++g) digitizer.acquire_group(group, info);
  digitizer.stop();
  EXPECT_EQ(counter.allocations(), 0u) << test_support::allocation_counting_method();
}

TEST(SimulatedDigitizer, WritesOnlyTheGroupIntoALargerSlot) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  digitizer.start();
  std::vector<std::uint16_t> slot(geometry.samples_per_group() + 64, 0xBEEF);
  hal::GroupInfo info;
  digitizer.acquire_group(slot, info);
  EXPECT_TRUE(std::all_of(slot.end() - 64, slot.end(), [](auto v) { return v == 0xBEEF; }));
  EXPECT_NE(slot[geometry.samples_per_group() - 1], 0xBEEF);
}

TEST(SimulatedDigitizer, RefusesMisuse) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  EXPECT_THROW(digitizer.start(), std::logic_error);
  EXPECT_THROW(digitizer.truth_at(0, 0), std::logic_error);
  digitizer.prepare(geometry);
  EXPECT_THROW(digitizer.acquire_group(group, info), std::logic_error);  // not started
  digitizer.start();
  EXPECT_THROW(digitizer.prepare(geometry), std::logic_error);  // while running
  std::vector<std::uint16_t> short_slot(geometry.samples_per_group() - 1);
  EXPECT_THROW(digitizer.acquire_group(short_slot, info), std::logic_error);
  EXPECT_NO_THROW(digitizer.acquire_group(group, info));
}

}  // namespace
}  // namespace ioct::sim
