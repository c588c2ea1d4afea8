// The B-scan pair through the instrument's tip: cut along and across the axis on a volume whose
// voxels say where they are, and on a simulated forceps scene, where the cut along the shaft shows
// the shaft's reflex above the tip on the shaft's side and none past the tip.
#include "ioct/gpu/instruments/tip_bscans.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

namespace ioct::gpu::instruments {
namespace {

using instruments_test::InstrumentScene;
using instruments_test::make_scene_volume;
using instruments_test::SceneVolume;

TEST(TipBscans, AlongAndAcrossTheAxisFollowTheVolumeAndAreBlackOutsideIt) {
  // 40 B-scans x 64 A-scans x 8 px; a voxel's value is its A-scan index + 100 on even B-scans
  // and its A-scan index on odd ones, whatever the depth.
  Volume v(40, 64, 8);
  for (std::uint32_t b = 0; b < v.bscans(); ++b) {
    for (std::uint32_t a = 0; a < v.ascans(); ++a) {
      for (std::uint32_t d = 0; d < v.depth(); ++d) {
        v.bscan(b)[std::size_t{a} * v.depth() + d] =
            static_cast<std::uint8_t>(a + (b % 2 ? 0 : 100));
      }
    }
  }
  segmentation::VolumeSampling sampling;
  sampling.ascan_spacing_um = 10.0;
  sampling.bscan_spacing_um = 40.0;
  InstrumentTip tip;
  tip.ascan = 32.0;
  tip.bscan = 20.0;  // an even B-scan
  tip.x_um = tip.ascan * sampling.ascan_spacing_um;
  tip.y_um = tip.bscan * sampling.bscan_spacing_um;
  tip.axis_x = 2.0;  // along +x; normalised inside
  tip.axis_y = 0.0;
  TipBscans pair;
  cut_tip_bscans(v, tip, sampling, pair, 200.0);
  ASSERT_EQ(pair.width, 40u);  // 2 x 200 um / 10 um
  ASSERT_EQ(pair.height, 8u);
  ASSERT_EQ(pair.pixels.size(), std::size_t{2} * 40 * 8);
  const auto at = [&](std::uint32_t column, std::uint32_t row) {
    return pair.pixels[std::size_t{row} * pair.stride() + column];
  };
  for (std::uint32_t row : {0u, 7u}) {
    // Along +x on B-scan 20: column c is A-scan 32 + (c - 20), on an even B-scan.
    for (std::uint32_t c = 0; c < pair.width; ++c) {
      EXPECT_EQ(at(c, row), 100 + 32 + static_cast<int>(c) - 20) << "along, column " << c;
    }
    // Across (+y): A-scan 32 throughout; B-scans 20 + (c - 20) / 4 (10 um steps over 40 um),
    // alternating 132 and 32 between which it interpolates.
    EXPECT_EQ(at(pair.width + 20, row), 132);  // the tip's own B-scan
    EXPECT_EQ(at(pair.width + 24, row), 32);   // one B-scan on
    EXPECT_EQ(at(pair.width + 22, row), 82);   // half way between them
  }

  // Near the field's edge the part of the cut outside the volume is black.
  tip.ascan = 2.0;
  tip.x_um = 20.0;
  cut_tip_bscans(v, tip, sampling, pair, 200.0);
  EXPECT_EQ(at(0, 0), 0) << "18 A-scans left of A-scan 0: outside";
  EXPECT_EQ(at(20, 0), 102) << "the tip itself";
}

TEST(TipBscans, AlongTheForcepsShaftTheReflexEndsAtTheTip) {
  const InstrumentScene scene{.name = "forceps above",
                              .kind = sim::InstrumentKind::forceps,
                              .tip_x = 0.0f,
                              .tip_y = 0.0f,
                              .above_ilm_um = 300.0,
                              .yaw_deg = 0.0f,
                              .pitch_deg = 20.0f};
  const SceneVolume s = make_scene_volume(scene);
  segmentation::Surfaces surfaces;
  segmentation::make_segmenter(Backend::cpu, {}, s.sampling, 2)
      ->segment_volume(s.filtered, surfaces);
  InstrumentFindings findings;
  make_instrument_detector(Backend::cpu, {}, s.sampling, 2)
      ->detect_volume(s.volume.volume, surfaces, findings);
  ASSERT_NE(findings.nearest_tip(), nullptr);
  const InstrumentTip& tip = *findings.nearest_tip();
  // The shaft leaves the tip towards yaw 0 (+x): the axis, from the shaft to the tip, is -x.
  EXPECT_LT(tip.axis_x, -0.9) << tip.axis_x << ", " << tip.axis_y;

  TipBscans pair;
  cut_tip_bscans(s.volume.volume, tip, s.sampling, pair);
  const std::uint32_t centre = pair.width / 2;
  // The brightest pixel above the retina in a column: the tool's reflex where the tool is.
  const auto reflex = [&](std::uint32_t column) {
    int best = 0;
    const auto ilm_row = static_cast<std::uint32_t>(s.ilm_px) - 10;
    for (std::uint32_t row = 0; row < ilm_row; ++row) {
      best = std::max<int>(best, pair.pixels[std::size_t{row} * pair.stride() + column]);
    }
    return best;
  };
  // Shaft side (before the tip along the axis: columns left of the centre) against beyond it.
  int shaft = 255, beyond = 0;
  for (std::uint32_t c = centre - 40; c < centre - 10; ++c) shaft = std::min(shaft, reflex(c));
  for (std::uint32_t c = centre + 10; c < centre + 40; ++c) beyond = std::max(beyond, reflex(c));
  std::printf("[ figures  ] shaft reflex min %d, beyond the tip max %d (u8)\n", shaft, beyond);
  EXPECT_GT(shaft, beyond + 40) << "the shaft shows bright on its side of the tip and stops there";
}

}  // namespace
}  // namespace ioct::gpu::instruments
