// The simulated digitizer: its spectra put the layers where its ground truth says, the same seed
// gives the same bytes, the truth it reports per group, and acquisition allocates nothing.
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

// ILM: the first bin from the top that stands well out of the noise, moved to the local maximum
// just below it; RPE: the brightest bin of the outer retina (from 100 um below the ILM down).
// What a segmentation does first, with no knowledge of the truth.
struct Found {
  std::uint32_t ilm;
  std::uint32_t rpe;
};
Found find_layers(std::span<const float> magnitude, float threshold) {
  std::uint32_t ilm = 64;  // past the DC and fixed-pattern bins
  while (ilm < magnitude.size() && magnitude[ilm] < threshold) ++ilm;
  for (std::uint32_t k = 0; k < 2 && ilm + 1 < magnitude.size(); ++k) {
    if (magnitude[ilm + 1] > magnitude[ilm]) ++ilm;
  }
  std::uint32_t rpe = ilm + 25;
  for (std::uint32_t bin = rpe; bin < magnitude.size(); ++bin) {
    if (magnitude[bin] > magnitude[rpe]) rpe = bin;
  }
  return {ilm, rpe};
}

TEST(SimulatedDigitizer, PlainFftPutsIlmAndRpeAtTheGroundTruth) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulatedDigitizer digitizer(test_simulation(geometry));
  digitizer.prepare(geometry);
  digitizer.start();
  const std::vector<std::uint16_t> group = acquire(digitizer);
  const GroupTruth& truth = digitizer.last_group_truth();
  const std::vector<double> background = test::mean_spectrum(group, geometry.samples_per_ascan);

  test::SpectrumFft fft(geometry.samples_per_ascan);
  const std::uint32_t n = geometry.samples_per_ascan;
  std::size_t ascans = 0;
  std::size_t ilm_hits = 0;
  std::size_t rpe_hits = 0;
  double ilm_error = 0.0;
  double rpe_error = 0.0;
  float thinnest = 1e9f;
  float thickest = 0.0f;
  for (std::uint32_t line = 0; line < geometry.bscans_per_group; ++line) {
    for (std::uint32_t ascan = 0; ascan < geometry.ascans_per_bscan; ++ascan) {
      const std::size_t record = std::size_t{line} * geometry.ascans_per_bscan + ascan;
      const auto magnitude =
          fft.magnitude(std::span<const std::uint16_t>(group).subspan(record * n, n), background);
      const float ilm = truth.ilm_px[record];
      const float rpe = truth.rpe_px[record];
      ASSERT_TRUE(std::isfinite(ilm) && std::isfinite(rpe)) << record;
      // The truth per group is the raster's truth (no galvo: the beam is where commanded).
      const LayerTruth at = digitizer.truth_at(line, ascan);
      EXPECT_EQ(at.ilm_px, ilm);
      EXPECT_EQ(at.rpe_px, rpe);
      const float noise = test::median_magnitude(magnitude, n / 2 - 120, n / 2);
      const Found found = find_layers(magnitude, 12.0f * noise);
      ++ascans;
      ilm_hits += std::abs(static_cast<float>(found.ilm) - ilm) <= 1.0f;
      rpe_hits += std::abs(static_cast<float>(found.rpe) - rpe) <= 1.0f;
      ilm_error += std::abs(static_cast<float>(found.ilm) - ilm);
      rpe_error += std::abs(static_cast<float>(found.rpe) - rpe);
      thinnest = std::min(thinnest, rpe - ilm);
      thickest = std::max(thickest, rpe - ilm);
    }
  }
  std::printf(
      "[ layers   ] ILM within 1 px in %zu of %zu A-scans (mean error %.2f px), RPE in %zu "
      "(%.2f px)\n",
      ilm_hits, ascans, ilm_error / static_cast<double>(ascans), rpe_hits,
      rpe_error / static_cast<double>(ascans));
  // Speckle makes a few A-scans' lines dim; nearly all must be found where the truth says.
  EXPECT_GE(ilm_hits, ascans * 97 / 100);
  EXPECT_GE(rpe_hits, ascans * 97 / 100);
  EXPECT_LT(ilm_error / static_cast<double>(ascans), 0.6);
  EXPECT_LT(rpe_error / static_cast<double>(ascans), 0.6);
  // The raster crosses the foveal pit: there the retina is about half as thick.
  EXPECT_LT(thinnest, 0.65f * thickest);
}

TEST(SimulatedDigitizer, SameSeedGivesIdenticalBytesAndAnotherSeedDiffers) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulationConfig with_tool = test_simulation(geometry, 11);
  with_tool.instruments.push_back(
      {InstrumentKind::forceps, {0.1f, 0.0f, 0.4f, 180.0f, 25.0f, 15.0f}, {}});
  SimulatedDigitizer first(with_tool);
  SimulatedDigitizer second(with_tool);
  SimulationConfig other_seed = with_tool;
  other_seed.seed = 12;
  SimulatedDigitizer other(other_seed);
  for (SimulatedDigitizer* digitizer : {&first, &second, &other}) {
    digitizer->prepare(geometry);
    digitizer->start();
  }
  for (int g = 0; g < 2; ++g) {
    const std::vector<std::uint16_t> a = acquire(first);
    const std::vector<std::uint16_t> b = acquire(second);
    const std::vector<std::uint16_t> c = acquire(other);
    EXPECT_EQ(a, b) << "group " << g;
    EXPECT_TRUE(recording::same_bytes(first.last_group_truth(), second.last_group_truth()));
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
    EXPECT_EQ(digitizer.last_group_truth().first_sweep_counter, info.first_sweep_counter);
    EXPECT_EQ(digitizer.last_group_truth().group_index, g);
  }
}

TEST(SimulatedDigitizer, SamplesStayWithinTheAdcRangeAndSwingAboutTheBackground) {
  hal::DigitizerConfig geometry = test_geometry();
  geometry.bscans_per_group = 2;
  for (const std::uint32_t bits : {12u, 10u, 14u}) {
    geometry.sample_bits = bits;
    SimulatedDigitizer digitizer(test_simulation(geometry));
    digitizer.prepare(geometry);
    digitizer.start();
    const std::vector<std::uint16_t> group = acquire(digitizer);
    const auto [low, high] = std::minmax_element(group.begin(), group.end());
    EXPECT_LE(*high, (1u << bits) - 1) << bits << " bits";
    // Balanced detection sits about mid-scale (the offset plus a little reference light)...
    EXPECT_GT(*low, 1u << (bits - 2)) << bits << " bits";
    EXPECT_LT(*high, 3u << (bits - 2)) << bits << " bits";
    // ... and the fringes swing both ways about the background, by counts that scale with bits.
    const std::vector<double> background = test::mean_spectrum(group, geometry.samples_per_ascan);
    double below = 0.0;
    double above = 0.0;
    for (std::size_t i = 0; i < group.size(); ++i) {
      const double d = group[i] - background[i % geometry.samples_per_ascan];
      below = std::min(below, d);
      above = std::max(above, d);
    }
    const double scale = std::ldexp(1.0, static_cast<int>(bits) - 12);
    EXPECT_LT(below, -30.0 * scale) << bits << " bits";
    EXPECT_GT(above, 30.0 * scale) << bits << " bits";
  }
}

TEST(SimulatedDigitizer, AcquiringAGroupAllocatesNothing) {
  const hal::DigitizerConfig geometry = test_geometry();
  SimulationConfig simulation = test_simulation(geometry);
  simulation.instruments.push_back(
      {InstrumentKind::scraper, {0.0f, 0.0f, 0.35f, 30.0f, 20.0f, 0.0f}, {}});
  for (const hal::ClockSource clock :
       {hal::ClockSource::external_k_clock, hal::ClockSource::internal}) {
    hal::DigitizerConfig config = geometry;
    config.clock_source = clock;
    SimulatedDigitizer digitizer(simulation);
    digitizer.prepare(config);
    std::vector<std::uint16_t> group(config.samples_per_group());
    hal::GroupInfo info;
    const test_support::AllocationCounter counter;
    digitizer.start();
    for (int g = 0; g < 2; ++g) digitizer.acquire_group(group, info);
    digitizer.stop();
    EXPECT_EQ(counter.allocations(), 0u) << test_support::allocation_counting_method();
  }
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
  EXPECT_THROW(digitizer.last_group_truth(), std::logic_error);
  digitizer.prepare(geometry);
  EXPECT_THROW(digitizer.acquire_group(group, info), std::logic_error);  // not started
  digitizer.start();
  EXPECT_THROW(digitizer.prepare(geometry), std::logic_error);  // while running
  std::vector<std::uint16_t> short_slot(geometry.samples_per_group() - 1);
  EXPECT_THROW(digitizer.acquire_group(short_slot, info), std::logic_error);
  EXPECT_NO_THROW(digitizer.acquire_group(group, info));
}

TEST(SimulatedDigitizer, TruthFollowsAMovingInstrument) {
  hal::DigitizerConfig geometry = test_geometry();
  geometry.ascan_rate_hz = 10'000.0;  // 90 ms per group: the tool moves visibly
  SimulationConfig simulation = test_simulation(geometry);
  InstrumentConfig needle;
  needle.kind = InstrumentKind::needle;
  needle.pose = {-0.5f, 0.0f, 0.45f, 180.0f, 20.0f, 0.0f};
  needle.motion.velocity_x = 2.0f;  // scan units per second
  simulation.instruments.push_back(needle);
  SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(geometry);
  digitizer.start();
  acquire(digitizer);
  const GroupTruth& truth = digitizer.last_group_truth();
  ASSERT_EQ(truth.tools, 1u);
  ASSERT_EQ(truth.tool_states.size(), geometry.bscans_per_group);
  const double line_seconds =
      static_cast<double>(geometry.sweeps_per_bscan()) / geometry.ascan_rate_hz;
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    EXPECT_NEAR(truth.tool_states[b].tip_x, -0.5 + 2.0 * b * line_seconds, 1e-5) << b;
    EXPECT_NEAR(truth.tool_states[b].tip_depth_px, 0.45 * 688, 1e-3);
  }
  // Under the needle the beam sees it (its surface above the ILM), beside it the retina.
  std::size_t hits = 0;
  for (std::size_t r = 0; r < truth.ascans(); ++r) {
    if (std::isfinite(truth.tool_px[r])) {
      ++hits;
      EXPECT_LT(truth.tool_px[r], truth.ilm_px[r]);
      EXPECT_LT(truth.beam_x[r], truth.tool_states[r / geometry.ascans_per_bscan].tip_x + 0.3f)
          << "the shaft goes towards -x from the tip";
    }
  }
  EXPECT_GT(hits, 10u);
}

}  // namespace
}  // namespace ioct::sim
