// The rolling background (a mean over the last N groups) and the averaging of repeated B-scans.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <vector>

#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "processing_fixture.hpp"

namespace ioct::gpu {
namespace {

using testing::Reflector;

shm::RingGeometry small_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 256;
  g.ascans_per_bscan = 24;
  g.bscans_per_group = 4;
  g.bscans_per_volume = 8;
  return g;
}

TEST(RollingBackground, IsTheMeanOverTheLastGroupsWeightedByTheirAscans) {
  const shm::RingGeometry g = small_geometry();
  OctProcessorConfig config = testing::quick_config();
  config.background.groups = 3;
  CpuOctProcessor processor(config);
  processor.prepare(g);
  ProcessedGroup out;
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  // Group i: every sample of every active record is level[i] + s % 7; active widths differ, so
  // the groups weigh differently in the mean. Inactive records hold 4000 and must not count.
  const std::uint32_t level[] = {100, 900, 400, 2500, 1300};
  const std::uint32_t widths[] = {24, 10, 20, 16, 24};
  std::vector<double> sums(g.samples_per_ascan, 0.0);
  for (std::uint32_t i = 0; i < 5; ++i) {
    for (std::size_t k = 0; k < payload.size(); ++k) {
      const auto s = static_cast<std::uint32_t>(k % g.samples_per_ascan);
      const auto record =
          static_cast<std::uint32_t>((k / g.samples_per_ascan) % g.ascans_per_bscan);
      payload[k] = static_cast<std::uint16_t>(record < widths[i] ? level[i] + s % 7 : 4000);
    }
    processor.process(RawGroup{testing::header_for(g, 0, widths[i], i), payload}, out);
    // Expected: the last min(i + 1, 3) groups, each weighted by its A-scans.
    double total_ascans = 0.0;
    std::fill(sums.begin(), sums.end(), 0.0);
    for (std::uint32_t j = (i >= 2 ? i - 2 : 0); j <= i; ++j) {
      const double ascans = static_cast<double>(widths[j]) * g.bscans_per_group;
      total_ascans += ascans;
      for (std::uint32_t s = 0; s < g.samples_per_ascan; ++s)
        sums[s] += ascans * (level[j] + s % 7);
    }
    for (std::uint32_t s = 0; s < g.samples_per_ascan; ++s) {
      ASSERT_FLOAT_EQ(processor.last_background()[s], static_cast<float>(sums[s] / total_ascans))
          << "group " << i << " sample " << s;
    }
  }
  // prepare() forgets the history: the next group's background is its own mean.
  processor.prepare(g);
  processor.process(RawGroup{testing::header_for(g, 0, 24), payload}, out);
  EXPECT_FLOAT_EQ(processor.last_background()[0], 1300.0f);
}

TEST(RollingBackground, RemovesAFixedPatternButKeepsMovingTissue) {
  const shm::RingGeometry g = small_geometry();
  // A reflection in the optics at depth 30 (the same phase in every sweep) and tissue at 70
  // (random phase from A-scan to A-scan, as moving tissue has).
  testing::SpectrumModel model{.samples = g.samples_per_ascan, .noise_sigma = 1.0};
  model.fixed_pattern_depth = 30.0;
  model.fixed_pattern_amplitude = 40.0;
  testing::SpectrumSynthesizer synthesizer(model, 3);
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  OctProcessorConfig config = testing::quick_config();
  config.background.groups = 4;
  CpuOctProcessor with(config);
  config.background.mode = BackgroundMode::none;
  CpuOctProcessor without(config);
  with.prepare(g);
  without.prepare(g);
  ProcessedGroup a;
  ProcessedGroup b;
  for (int group = 0; group < 4; ++group) {
    testing::fill_group(
        g, synthesizer,
        [](std::uint32_t, std::uint32_t) {
          return std::vector<Reflector>{{70.0, 40.0}};
        },
        payload);
    const shm::SlotHeader header = testing::header_for(g, 0, g.ascans_per_bscan);
    with.process(RawGroup{header, payload}, a);
    without.process(RawGroup{header, payload}, b);
  }
  double fixed_with = 0;
  double fixed_without = 0;
  double tissue_with = 0;
  for (std::uint32_t bscan = 0; bscan < a.bscan_count; ++bscan) {
    for (std::uint32_t ascan = 0; ascan < a.ascans; ++ascan) {
      fixed_with += testing::ascan_of(a, bscan, ascan)[30];
      fixed_without += testing::ascan_of(b, bscan, ascan)[30];
      tissue_with += testing::ascan_of(a, bscan, ascan)[70];
    }
  }
  const double n = static_cast<double>(a.bscan_count * a.ascans);
  EXPECT_GT(fixed_without / n, 180.0);  // the fixed pattern shows without removal
  EXPECT_LT(fixed_with / n, 40.0);      // and is gone with it
  EXPECT_GT(tissue_with / n, 180.0);    // while the tissue stays
}

TEST(Repeats, RepeatedBscansAverageInPowerAndLineUpWhenBidirectional) {
  shm::RingGeometry g = small_geometry();  // 4 B-scans per group: 2 positions x 2 repeats
  testing::SpectrumModel model{.samples = g.samples_per_ascan, .noise_sigma = 0.5};
  testing::SpectrumSynthesizer synthesizer(model, 9);
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  // Repeat 0 of each position forward, repeat 1 reversed; column c has its reflector at 40 + c
  // in both. Amplitudes 30 (repeat 0) and 60 (repeat 1): the mean power is that of
  // sqrt((30^2 + 60^2) / 2) = 47.4 counts.
  const std::uint32_t width = g.ascans_per_bscan;
  testing::fill_group(
      g, synthesizer,
      [&](std::uint32_t b, std::uint32_t record) {
        const bool reversed = b % 2 == 1;
        const std::uint32_t column = reversed ? width - 1 - record : record;
        return std::vector<Reflector>{{40.0 + column, reversed ? 60.0 : 30.0}};
      },
      payload);
  shm::SlotHeader header = testing::header_for(g, 0, width);
  for (std::uint32_t b = 0; b < 4; ++b) {
    header.bscans[b].bscan_in_volume = b / 2;  // the position
    header.bscans[b].flags = b % 2 == 1 ? shm::kBscanReversed : 0;
  }
  header.bscans[3].flags |= shm::kBscanVolumeEnd;  // on the last repeat only

  OctProcessorConfig config = testing::quick_config();
  config.background.mode = BackgroundMode::none;
  config.window.kind = WindowKind::rectangular;
  config.repeats_per_position = 2;
  CpuOctProcessor processor(config);
  processor.prepare(g);
  ProcessedGroup out;
  processor.process(RawGroup{header, payload}, out);
  ASSERT_EQ(out.bscan_count, 2u);
  EXPECT_EQ(out.markers[0].bscan_in_volume, 0u);
  EXPECT_EQ(out.markers[1].bscan_in_volume, 1u);
  EXPECT_NE(out.markers[1].flags & shm::kBscanVolumeEnd, 0u);
  EXPECT_EQ(out.markers[0].flags & shm::kBscanVolumeEnd, 0u);

  // The same spectra with only the repeat-0 B-scans at amplitude 47.4 would give this pixel:
  const DbToU8 scale(config.scale, g.samples_per_ascan);
  const double amplitude = std::sqrt((30.0 * 30.0 + 60.0 * 60.0) / 2.0);
  // A rectangular window: a fringe A env(s) cos(2 pi z s / N) at an integer bin z reads
  // A / 2 sum_s env(s) in |X|.
  double envelope_sum = 0.0;
  for (std::uint32_t s = 0; s < g.samples_per_ascan; ++s)
    envelope_sum += synthesizer.envelope_at(s);
  const double bin = amplitude / 2.0 * envelope_sum;
  for (std::uint32_t p = 0; p < out.bscan_count; ++p) {
    for (std::uint32_t c = 0; c < width; ++c) {
      const auto ascan = testing::ascan_of(out, p, c);
      // (Past the DC of the unremoved background, which holds the first few pixels.)
      EXPECT_EQ(10 + testing::brightest_depth(ascan.subspan(10)), 40 + c)
          << "position " << p << " column " << c;
      EXPECT_NEAR(ascan[40 + c], scale.pixel(static_cast<float>(bin * bin)), 2)
          << "position " << p << " column " << c;
    }
  }
  // A group whose B-scans are not whole positions is rejected.
  header.bscan_count = 3;
  EXPECT_THROW(processor.process(RawGroup{header, payload}, out), std::invalid_argument);
}

}  // namespace
}  // namespace ioct::gpu
