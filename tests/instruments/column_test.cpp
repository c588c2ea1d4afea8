// The column classification and the tips on hand-made volumes: what each kind of A-scan looks
// like, where the reflex is, and a tool drawn into a flat "retina" found with its tip where it
// was drawn and its distance to the surfaces given.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "ioct/gpu/instruments/column_classification.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/instruments/tip_finder.hpp"

namespace ioct::gpu::instruments {
namespace {

constexpr std::uint32_t kDepth = 400;

ColumnParams params() {
  VolumeSampling sampling;
  sampling.axial_um_per_px = 5.0;
  return make_column_params(InstrumentConfig{}, sampling, kDepth);
}

// A retina: bright from 200 to 320 px with a darker band inside, nothing below 330.
void draw_retina(std::uint8_t* column) {
  for (int z = 200; z < 320; ++z) column[z] = (z >= 240 && z < 260) ? 20 : 120;
}

TEST(ColumnClassification, RetinaAloneIsClear) {
  std::vector<std::uint8_t> column(kDepth, 0);
  draw_retina(column.data());
  EXPECT_EQ(classify_column(column.data(), params(), 0).kind, ColumnKind::clear);
}

TEST(ColumnClassification, NothingAtAllIsClear) {
  const std::vector<std::uint8_t> column(kDepth, 3);
  EXPECT_EQ(classify_column(column.data(), params(), 3).kind, ColumnKind::clear);
}

TEST(ColumnClassification, MetalReflexOverAShadowIsShadowWithItsPeak) {
  std::vector<std::uint8_t> column(kDepth, 0);
  column[149] = 150;
  column[150] = 250;
  column[151] = 150;
  const ColumnFinding f = classify_column(column.data(), params(), 0);
  EXPECT_EQ(f.kind, ColumnKind::shadow);
  EXPECT_FLOAT_EQ(f.reflex_px, 150.0f);
  EXPECT_FLOAT_EQ(f.front_px, 0.0f);  // metal: no front to read
}

TEST(ColumnClassification, TheReflexBelowTissueIsTheToolsNotTheTissues) {
  // The tool inside the retina: tissue from 200, the metal at 230, nothing beneath.
  std::vector<std::uint8_t> column(kDepth, 0);
  for (int z = 200; z < 229; ++z) column[z] = 250;  // brighter tissue above the tool
  column[229] = 100;
  column[230] = 200;
  column[231] = 100;
  const ColumnFinding f = classify_column(column.data(), params(), 0);
  EXPECT_EQ(f.kind, ColumnKind::shadow);
  EXPECT_FLOAT_EQ(f.reflex_px, 230.0f);
}

TEST(ColumnClassification, ADarkBandInTheTissueAboveTheToolDoesNotHideIt) {
  // Tissue from 200 with a dark band (the outer nuclear layer) longer than the gap, the metal at
  // 232, nothing beneath.
  std::vector<std::uint8_t> column(kDepth, 0);
  for (int z = 200; z < 231; ++z) column[z] = (z >= 210 && z < 220) ? 2 : 90;
  column[231] = 100;
  column[232] = 220;
  column[233] = 100;
  const ColumnFinding f = classify_column(column.data(), params(), 0);
  EXPECT_EQ(f.kind, ColumnKind::shadow);
  EXPECT_FLOAT_EQ(f.reflex_px, 232.0f);
}

TEST(ColumnClassification, WeakSignalBeneathIsNoShadow) {
  // A reflex with tissue beneath it that stays below object_margin but well above the floor.
  std::vector<std::uint8_t> column(kDepth, 0);
  column[150] = 250;
  for (int z = 160; z < 300; ++z) column[z] = 25;
  EXPECT_EQ(classify_column(column.data(), params(), 0).kind, ColumnKind::clear);
}

TEST(ColumnClassification, AReflexNearTheBottomCastsNoShadowToSee) {
  std::vector<std::uint8_t> column(kDepth, 0);
  column[kDepth - 10] = 250;
  EXPECT_EQ(classify_column(column.data(), params(), 0).kind, ColumnKind::clear);
}

TEST(ColumnClassification, TranslucentToolAboveTheRetinaIsPartialAtItsMiddle) {
  std::vector<std::uint8_t> column(kDepth, 0);
  for (int z = 100; z < 130; ++z) column[z] = 180;
  draw_retina(column.data());
  const ColumnFinding f = classify_column(column.data(), params(), 0);
  EXPECT_EQ(f.kind, ColumnKind::partial);
  EXPECT_FLOAT_EQ(f.reflex_px, 114.5f);
  EXPECT_FLOAT_EQ(f.front_px, 100.0f);  // its front surface: half its height above the middle
}

TEST(ColumnClassification, ADimFloaterAboveTheRetinaIsClear) {
  std::vector<std::uint8_t> column(kDepth, 0);
  for (int z = 100; z < 105; ++z) column[z] = 50;  // above object_margin, below the partial's
  draw_retina(column.data());
  EXPECT_EQ(classify_column(column.data(), params(), 0).kind, ColumnKind::clear);
}

TEST(ColumnClassification, TheFloorRaisesEveryLevel) {
  std::vector<std::uint8_t> column(kDepth, 30);
  column[150] = 60;  // 30 above a floor of 30: below object_margin
  EXPECT_EQ(classify_column(column.data(), params(), 30).kind, ColumnKind::clear);
  column[150] = 250;
  EXPECT_EQ(classify_column(column.data(), params(), 30).kind, ColumnKind::shadow);
}

// A flat retina (ILM 200 px, RPE 300 px) and a needle along +x whose end is a sphere of 20 A-scans'
// radius centred at A-scan 40, B-scan 20: its reflexes on the sphere in front of the centre, a
// straight top behind it; everything beneath it black.
struct DrawnNeedle {
  static constexpr double kRadiusUm = 100.0, kCenterPx = 150.0;
  VolumeSampling sampling;
  InstrumentConfig config;
  Volume volume;
  segmentation::Surfaces surfaces;
};

DrawnNeedle drawn_needle() {
  DrawnNeedle n;
  n.sampling.axial_um_per_px = 5.0;
  n.sampling.ascan_spacing_um = 10.0;
  n.sampling.bscan_spacing_um = 10.0;
  n.config.medium_group_index = 1.0;
  const std::uint32_t bscans = 41, ascans = 120;
  n.volume = Volume(bscans, ascans, kDepth);
  n.surfaces.reset(bscans, ascans, kDepth);
  const double radius_um = DrawnNeedle::kRadiusUm;
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint32_t a = 0; a < ascans; ++a) {
      auto column = n.volume.bscan(b).subspan(std::size_t{a} * kDepth, kDepth);
      std::fill(column.begin(), column.end(), std::uint8_t{0});
      const std::size_t k = n.surfaces.index(b, a);
      n.surfaces.state[k] = segmentation::SurfaceState::measured;
      n.surfaces.ilm[k] = 200.0f;
      n.surfaces.rpe[k] = 300.0f;
      const double dx = (static_cast<double>(a) - 40.0) * 10.0;
      const double dy = (static_cast<double>(b) - 20.0) * 10.0;
      const double across2 = dy * dy;
      const double d2 = dx <= 0.0 ? dx * dx + across2 : across2;  // the shaft runs to +x
      if (d2 < radius_um * radius_um) {
        const double top = DrawnNeedle::kCenterPx - std::sqrt(radius_um * radius_um - d2) / 5.0;
        column[static_cast<std::size_t>(std::lround(top))] = 250;
      } else {
        for (std::uint32_t z = 200; z < 320; ++z) column[z] = 120;
      }
    }
  }
  return n;
}

TEST(Tips, AToolDrawnIntoAFlatRetinaIsFoundWhereItWasDrawn) {
  DrawnNeedle n = drawn_needle();
  const Volume& volume = n.volume;
  const segmentation::Surfaces& surfaces = n.surfaces;
  const VolumeSampling& sampling = n.sampling;
  InstrumentConfig& config = n.config;
  const double center_px = DrawnNeedle::kCenterPx;
  InstrumentFindings findings;
  make_instrument_detector(Backend::cpu, config, sampling, 1)
      ->detect_volume(volume, surfaces, findings);
  ASSERT_EQ(findings.tips.size(), 1u);
  const InstrumentTip& tip = findings.tips[0];
  EXPECT_NEAR(tip.ascan, 40.0, 1.0);
  EXPECT_NEAR(tip.bscan, 20.0, 1.0);
  EXPECT_NEAR(tip.depth_px, center_px, 1.5);
  EXPECT_EQ(tip.source, DistanceSource::inferred);
  EXPECT_NEAR(tip.to_ilm_um, (200.0 - tip.depth_px) * 5.0, 1e-6);
  EXPECT_NEAR(tip.to_rpe_um, (300.0 - tip.depth_px) * 5.0, 1e-6);
  EXPECT_NEAR(tip.x_um, tip.ascan * 10.0, 1e-9);
  EXPECT_FALSE(findings.warning);  // 750 um above the RPE

  // Within the warning distance of the RPE, the warning is raised.
  config.warn_rpe_um = 1000.0;
  make_instrument_detector(Backend::cpu, config, sampling, 1)
      ->detect_volume(volume, surfaces, findings);
  EXPECT_TRUE(findings.warning);
  EXPECT_NE(describe(findings).find("WARNING"), std::string::npos);
}

TEST(Tips, AVolumeWithoutToolsHasNone) {
  Volume volume(8, 64, kDepth);
  for (std::uint32_t b = 0; b < 8; ++b) {
    for (std::uint32_t a = 0; a < 64; ++a) {
      draw_retina(volume.bscan(b).data() + std::size_t{a} * kDepth);
    }
  }
  InstrumentFindings findings;
  make_instrument_detector(Backend::cpu, {}, {}, 2)->detect_volume(volume, {}, findings);
  EXPECT_TRUE(findings.tips.empty());
  EXPECT_EQ(findings.nearest_tip(), nullptr);
  EXPECT_EQ(describe(findings), "no instrument");
}

TEST(Tips, GroupsOutsideTheVolumeAreRefused) {
  Volume volume(8, 64, kDepth);
  InstrumentFindings findings;
  const auto detector = make_instrument_detector(Backend::cpu, {}, {}, 1);
  EXPECT_THROW(detector->detect_group(volume, {6, 4}, {}, findings), std::out_of_range);
}

// detect_group in two halves (the live stages filter and segment between them): begun group by
// group and ended once, or a group begun while another is pending (which ends that one first,
// without tips), the findings are detect_volume's to the bit. Ending none, or other findings, is
// refused.
TEST(Tips, AGroupBegunAndEndedLaterIsDetectGroupInTwoHalves) {
  const DrawnNeedle n = drawn_needle();
  const auto detector = make_instrument_detector(Backend::cpu, n.config, n.sampling, 2);
  InstrumentFindings whole;
  detector->detect_volume(n.volume, n.surfaces, whole);
  ASSERT_EQ(whole.tips.size(), 1u);

  InstrumentFindings halves;
  for (std::uint32_t first = 0; first < n.volume.bscans(); first += 8) {
    const std::uint32_t count = std::min(8u, n.volume.bscans() - first);
    detector->begin_group(VolumeRef::on_host(n.volume), {first, count}, halves);
  }
  detector->end_group(n.surfaces, halves);
  EXPECT_EQ(halves.columns, whole.columns);
  EXPECT_EQ(halves.mask, whole.mask);
  ASSERT_EQ(halves.tips.size(), 1u);
  EXPECT_EQ(halves.tips[0].ascan, whole.tips[0].ascan);
  EXPECT_EQ(halves.tips[0].bscan, whole.tips[0].bscan);
  EXPECT_EQ(halves.tips[0].depth_px, whole.tips[0].depth_px);
  EXPECT_EQ(halves.tips[0].to_rpe_um, whole.tips[0].to_rpe_um);

  EXPECT_THROW(detector->end_group(n.surfaces, halves), std::logic_error);  // none pending
  InstrumentFindings other;
  detector->begin_group(VolumeRef::on_host(n.volume), {0, 8}, halves);
  EXPECT_THROW(detector->end_group(n.surfaces, other), std::logic_error);
  detector->end_group(n.surfaces, halves);  // still pending after the refusal
  EXPECT_EQ(halves.tips.size(), 1u);
}

// A tool whose rounded end's centre lies beyond the volume's first A-scan: its fitted sphere's
// centre (the tip) falls before A-scan 0, more than one A-scan out. The surfaces at the tip then
// come from its one side only, and nothing reads before the mask (an earlier search started at a
// negative index there; ASan saw it).
TEST(Tips, ATipFittedBeforeTheVolumeTakesItsSurfacesFromInside) {
  constexpr std::uint32_t kBscans = 8, kAscans = 96;
  segmentation::VolumeSampling sampling;
  sampling.ascan_spacing_um = 10.0;
  sampling.bscan_spacing_um = 10.0;
  sampling.axial_um_per_px = 4.0;
  InstrumentConfig config;
  InstrumentFindings findings;
  findings.reset(kBscans, kAscans);
  // A wide tool (a capsule of radius 250 um) coming in from the left over a field 80 um high:
  // its end's centre lies at x = -50 um, outside the field, and only the front of its cap
  // (x >= 0, 200 um long, cut by the field's top and bottom) is scanned.
  const double radius = 250.0, tx = -50.0, ty = 35.0, ex = -2000.0, ey = 35.0;
  const double um_per_px_medium = sampling.axial_um_per_px / config.medium_group_index;
  for (std::uint32_t b = 0; b < kBscans; ++b) {
    for (std::uint32_t a = 0; a < kAscans; ++a) {
      const double x = a * sampling.ascan_spacing_um, y = b * sampling.bscan_spacing_um;
      const double vx = ex - tx, vy = ey - ty;
      const double t = std::clamp(((x - tx) * vx + (y - ty) * vy) / (vx * vx + vy * vy), 0.0, 1.0);
      const double d = std::hypot(x - (tx + t * vx), y - (ty + t * vy));
      if (d >= radius) continue;
      const std::size_t k = findings.index(b, a);
      findings.columns[k] = ColumnKind::shadow;
      findings.reflex_px[k] =
          static_cast<float>(200.0 - std::sqrt(radius * radius - d * d) / um_per_px_medium);
    }
  }
  segmentation::Surfaces surfaces;
  surfaces.reset(kBscans, kAscans, 688);
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    surfaces.state[k] = segmentation::SurfaceState::measured;
    surfaces.ilm[k] = 300.0f;
    surfaces.rpe[k] = 400.0f;
  }
  find_tips(findings, surfaces, config, sampling);
  ASSERT_EQ(findings.tips.size(), 1u);
  const InstrumentTip& tip = findings.tips[0];
  std::printf("[ tip      ] ascan %.2f bscan %.2f depth %.1f px, ILM %.1f RPE %.1f px (%s)\n",
              tip.ascan, tip.bscan, tip.depth_px, tip.ilm_px, tip.rpe_px,
              tip.source == DistanceSource::inferred ? "inferred" : "measured");
  EXPECT_LT(tip.ascan, -1.0) << "the fitted end lies before the first A-scan";
  EXPECT_EQ(tip.source, DistanceSource::inferred);
  EXPECT_FLOAT_EQ(static_cast<float>(tip.ilm_px), 300.0f);
  EXPECT_FLOAT_EQ(static_cast<float>(tip.rpe_px), 400.0f);
}

}  // namespace
}  // namespace ioct::gpu::instruments
