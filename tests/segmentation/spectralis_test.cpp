// A real Spectralis circle B-scan (Heidelberg .vol export, 768 x 496 px, 3.87 um/px), filtered as
// the live system filters, segmented, and compared with the device's own ILM and BM (Bruch's
// membrane) lines.
//
// Compared columns: where both device lines exist and the tissue lies inside the image. Left of
// the point where the device's ILM comes closest to the top of the image (the circle runs out of
// the image there) the image shows tissue folded back into it, and the device's lines there are
// extrapolations; the last 32 columns before the lines end run out at the top as well. So the
// columns compared are those from 32 past the left fold to 32 before the lines end.
//
// Our RPE is the centre of the RPE band; our BM the outer side of that band where the RPE lies on
// Bruch's membrane, and the membrane's floor beneath where the RPE is lifted off it (drusen, a
// detached RPE: lifted_rpe.hpp), as the device's BM follows it. Our RPE centre differs from the
// device's BM by the lift there. The figures are printed for docs/segmentation.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/offline/heidelberg_vol.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "surface_errors.hpp"
#include "test_paths.hpp"

namespace ioct::seg_test {
namespace {

namespace seg = gpu::segmentation;

// Thresholds of this test (regression guards at what the method reaches, with a margin; the
// figures and where the differences come from are in docs/segmentation.md): the ILM's median
// difference within the aim of 2 px, its mean not (11.7 px against the aim of 2: at the disc,
// bands lifted off the retina over a gap, and a thick dim band whose retina beneath is less than
// twice as bright, where the tissue leaves the top of the image), seven in ten of the columns
// within 5 px; the BM's median within 5 px (4.53 px measured). Away from the disc (the columns
// from kFirstColumnAwayFromDisc on) the BM's mean against the device's BM line: 3.23 px measured
// against the aim of 3 (6.42 px while our BM followed the lifted RPE; what is left: next to the
// disc, where the device's line dives towards it, and where our band's outer side lies a few px
// deeper than the device's line); the RPE centre's mean against it, 8.6 px (the RPE is lifted
// off Bruch's membrane there, which the device's line follows).
constexpr double kMaxIlmMedianPx = 1.6;
constexpr double kMaxIlmMeanPx = 12.0;
constexpr double kMinIlmWithin5Px = 0.70;
constexpr double kMaxBmMedianPx = 5.0;
constexpr std::uint32_t kFirstColumnAwayFromDisc = 342;
constexpr double kMaxBmMeanAwayFromDiscPx = 3.3;
constexpr double kMaxRpeMeanAwayFromDiscPx = 9.0;
// Beneath the two stretches where the RPE is lifted off Bruch's membrane (drusen-like bumps), the
// BM on the membrane, not on the lifted RPE (0.72 and 2.06 px measured; 15.7 and 9.5 px while our
// BM followed the RPE).
struct Lift {
  std::uint32_t first, end;
  double max_bm_mean_px;
};
constexpr Lift kLifts[] = {{400, 440, 1.2}, {515, 548, 2.6}};

TEST(Spectralis, SurfacesAgreeWithTheDevicesLinesWhereTheTissueIsInTheImage) {
  const std::filesystem::path path = spectralis_file();
  ASSERT_TRUE(std::filesystem::exists(path)) << "test data missing: " << path;
  const gpu::offline::HeidelbergVol vol = gpu::offline::read_heidelberg_vol(path);
  gpu::Volume filtered;
  gpu::filters::make_volume_filter(gpu::Backend::cpu, {}, 1)
      ->filter_volume(gpu::offline::to_volume(vol), filtered);
  seg::VolumeSampling sampling;
  sampling.axial_um_per_px = vol.header.depth_spacing_mm * 1000.0;
  sampling.ascan_spacing_um = vol.header.ascan_spacing_mm * 1000.0;
  sampling.bscan_spacing_um = sampling.ascan_spacing_um;
  seg::Surfaces s;
  seg::make_segmenter(gpu::Backend::cpu, {}, sampling, 1)->segment_volume(filtered, s);
  ASSERT_EQ(s.verdict[0], seg::BscanVerdict::retina);

  const std::vector<float>& device_ilm = vol.bscans[0].layers.at(0);
  const std::vector<float>& device_bm = vol.bscans[0].layers.at(1);
  const std::uint32_t ascans = s.ascans;
  std::uint32_t fold = 0;
  std::uint32_t last = 0;
  float shallowest = INFINITY;
  for (std::uint32_t a = 0; a < ascans; ++a) {
    if (!std::isfinite(device_ilm[a]) || !std::isfinite(device_bm[a])) continue;
    last = a;
    if (a < ascans / 2 && device_ilm[a] < shallowest) {
      shallowest = device_ilm[a];
      fold = a;
    }
  }
  std::vector<bool> compared(ascans, false);
  for (std::uint32_t a = fold + 32; a + 32 <= last; ++a) compared[a] = true;

  const SurfaceErrors ilm = surface_errors(s.ilm, device_ilm, &compared);
  const SurfaceErrors bm = surface_errors(s.bm, device_bm, &compared);
  const SurfaceErrors rpe = surface_errors(s.rpe, device_bm, &compared);
  const auto within = [&](const std::vector<float>& ours, const std::vector<float>& theirs,
                          double limit) {
    std::size_t n = 0, good = 0;
    for (std::uint32_t a = 0; a < ascans; ++a) {
      if (!compared[a] || !std::isfinite(ours[a])) continue;
      ++n;
      good += std::fabs(ours[a] - theirs[a]) <= limit ? 1 : 0;
    }
    return n == 0 ? 0.0 : static_cast<double>(good) / static_cast<double>(n);
  };
  const double ilm_within = within(s.ilm, device_ilm, 2.0);
  const double ilm_within5 = within(s.ilm, device_ilm, 5.0);
  const double bm_within = within(s.bm, device_bm, 2.0);
  std::printf("[ figures  ] columns %u..%u of %u\n", fold + 32, last - 32, ascans);
  std::printf("[ figures  ] ILM vs device ILM: %s; within 2 px: %.0f%%, within 5 px: %.0f%%\n",
              ilm.describe().c_str(), 100.0 * ilm_within, 100.0 * ilm_within5);
  std::printf("[ figures  ] BM vs device BM: %s; within 2 px: %.0f%%\n", bm.describe().c_str(),
              100.0 * bm_within);
  std::printf("[ figures  ] RPE centre vs device BM: %s\n", rpe.describe().c_str());
  std::vector<bool> away_from_disc = compared;
  for (std::uint32_t a = 0; a < kFirstColumnAwayFromDisc && a < ascans; ++a) {
    away_from_disc[a] = false;
  }
  const SurfaceErrors bm_away = surface_errors(s.bm, device_bm, &away_from_disc);
  const SurfaceErrors rpe_away = surface_errors(s.rpe, device_bm, &away_from_disc);
  std::printf("[ figures  ] away from the disc (columns %u..%u): BM vs device BM: %s\n",
              kFirstColumnAwayFromDisc, last - 32, bm_away.describe().c_str());
  std::printf("[ figures  ] away from the disc: RPE centre vs device BM: %s\n",
              rpe_away.describe().c_str());
  EXPECT_EQ(ilm.missing, 0u);
  EXPECT_LE(ilm.median, kMaxIlmMedianPx);
  EXPECT_LE(ilm.mean_absolute, kMaxIlmMeanPx);
  EXPECT_LE(bm_away.mean_absolute, kMaxBmMeanAwayFromDiscPx);
  EXPECT_LE(rpe_away.mean_absolute, kMaxRpeMeanAwayFromDiscPx);
  EXPECT_GE(ilm_within5, kMinIlmWithin5Px);
  EXPECT_LE(bm.median, kMaxBmMedianPx);
  for (const Lift& lift : kLifts) {
    std::vector<bool> beneath(ascans, false);
    for (std::uint32_t a = lift.first; a < lift.end && a < ascans; ++a) beneath[a] = compared[a];
    const SurfaceErrors bm_lift = surface_errors(s.bm, device_bm, &beneath);
    std::printf("[ figures  ] beneath the lifted RPE (columns %u..%u): BM vs device BM: %s\n",
                lift.first, lift.end - 1, bm_lift.describe().c_str());
    EXPECT_GE(bm_lift.compared, lift.end - lift.first - 4) << "columns " << lift.first;
    EXPECT_EQ(bm_lift.missing, 0u);
    EXPECT_LE(bm_lift.mean_absolute, lift.max_bm_mean_px) << "columns " << lift.first;
  }
}

}  // namespace
}  // namespace ioct::seg_test
