// Accuracy against the simulator's ground truth over the instrument scenes: each scene's volume
// through the CPU chain and the volume filters, segmented and searched for instruments on the
// CPU, as ioct-gpu does live. Over all scenes: the tip within 2 voxels (p95, Euclidean over
// B-scan, A-scan and depth index) of the true tip (sim::InstrumentModel::tip_state), and the
// tip-to-ILM and tip-to-RPE distances within 15 um (p95) of the truth, are the targets;
// what is reached is asserted below. The figures are printed ("[ figures ]") for README.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/sim/instrument_spec.hpp"
#include "same_tips.hpp"

namespace ioct::instruments_test {
namespace {

using gpu::instruments::DistanceSource;
using gpu::instruments::InstrumentFindings;

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t k =
      static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1;
  return v[std::min(k, v.size() - 1)];
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Errors {
  std::vector<double> tip, ilm, rpe;
  void print(const char* what) const {
    std::printf(
        "[ figures  ] %s, %zu scenes: tip median %.2f p95 %.2f vox; ILM distance median "
        "%.1f p95 %.1f um; RPE distance median %.1f p95 %.1f um\n",
        what, tip.size(), median(tip), p95(tip), median(ilm), p95(ilm), median(rpe), p95(rpe));
  }
};

// What the detection reaches over every scene (README.md gives the figures), asserted a little
// above it so that a regression fails; p95 over ten scenes is the worst scene. The tip and the
// ILM distance: the targets (reached: 1.18 vox, 6.4 um); the RPE distance (3.2 um) and
// the metal tools with closed ends (0.54 vox), tighter.
constexpr double kTipP95Vox = 2.0;
constexpr double kIlmDistanceP95Um = 15.0;
constexpr double kRpeDistanceP95Um = 5.0;
constexpr double kMetalTipP95Vox = 1.0;

// A scene's volume segmented and searched for instruments on the CPU, as ioct-gpu does live.
InstrumentFindings detect(const SceneVolume& s) {
  gpu::segmentation::Surfaces surfaces;
  gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
      ->segment_volume(s.filtered, surfaces);
  InstrumentFindings findings;
  gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2)
      ->detect_volume(s.volume.volume, surfaces, findings);
  return findings;
}

// Euclidean, in voxels (B-scan, A-scan and depth index).
double tip_error_vox(const gpu::instruments::InstrumentTip& tip, const sim::VoxelPoint& truth) {
  const double db = tip.bscan - truth.bscan, da = tip.ascan - truth.ascan,
               dz = tip.depth_px - truth.depth_px;
  return std::sqrt(db * db + da * da + dz * dz);
}

TEST(InstrumentAccuracy, TipAndDistancesAgainstTheSimulatorsPose) {
  Errors all, metal;
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    const InstrumentFindings findings = detect(s);
    ASSERT_NE(findings.nearest_tip(), nullptr) << scene.name << ": no instrument found";
    EXPECT_EQ(findings.tips.size(), 1u) << scene.name;
    const auto& tip = *findings.nearest_tip();
    const double error = tip_error_vox(tip, s.tip);
    const double ilm_error = std::abs(tip.to_ilm_um - s.to_ilm_um);
    const double rpe_error = std::abs(tip.to_rpe_um - s.to_rpe_um);
    for (Errors* e : {&all, &metal}) {
      if (e == &metal &&
          (scene.kind == sim::InstrumentKind::scraper || scene.jaw_opening_deg > 0)) {
        continue;
      }
      e->tip.push_back(error);
      e->ilm.push_back(ilm_error);
      e->rpe.push_back(rpe_error);
    }
    std::printf(
        "[ figures  ] %-26s tip (%.1f %.1f %.1f) truth (%.1f %.1f %.1f) vox: error %.2f; ILM "
        "%+.1f (truth %+.1f) RPE %+.1f (truth %+.1f) um, %s\n",
        scene.name.c_str(), tip.bscan, tip.ascan, tip.depth_px, s.tip.bscan, s.tip.ascan,
        s.tip.depth_px, error, tip.to_ilm_um, s.to_ilm_um, tip.to_rpe_um, s.to_rpe_um,
        std::string(to_string(tip.source)).c_str());
    // A closed tool's tip is under the tool: its surfaces are inferred. Between open jaws the
    // retina is in view.
    EXPECT_EQ(tip.source,
              scene.jaw_opening_deg > 0 ? DistanceSource::measured : DistanceSource::inferred)
        << scene.name;
  }
  all.print("all");
  metal.print("metal, closed ends");
  RecordProperty("metal_tip_p95_vox", std::to_string(p95(metal.tip)));
  RecordProperty("all_tip_p95_vox", std::to_string(p95(all.tip)));
  EXPECT_LE(p95(all.tip), kTipP95Vox);
  EXPECT_LE(p95(all.ilm), kIlmDistanceP95Um);
  EXPECT_LE(p95(all.rpe), kRpeDistanceP95Um);
  EXPECT_LE(p95(metal.tip), kMetalTipP95Vox);
}

// The detection's halves as the live stages call them: the group begun, its tips located from the
// mask before the surfaces are at hand, then ended with them (the stages locate while the device
// segments). Every scene's findings are those of detect_volume, which runs the same steps back to
// back, to the bit. Between the two the tips have no distances; a scraper's paddle (it grows onto
// the ILM) waits for the surfaces with every tip. Misuse is refused; a group dropped after
// locating has no tips.
TEST(InstrumentAccuracy, TipsLocatedBeforeTheSurfacesArePlacedAsDetectVolumeFindsThem) {
  std::size_t located_early = 0, paddles_waiting = 0;
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    gpu::segmentation::Surfaces surfaces;
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
    const auto detector =
        gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2);
    InstrumentFindings whole;
    detector->detect_volume(s.volume.volume, surfaces, whole);
    ASSERT_FALSE(whole.tips.empty()) << scene.name;

    InstrumentFindings steps;
    const gpu::VolumeRef ref = gpu::VolumeRef::on_host(s.volume.volume);
    detector->begin_group(ref, {0, s.volume.volume.bscans()}, steps);
    detector->locate_tips(steps);
    EXPECT_EQ(steps.nearest, -1) << scene.name;
    for (const auto& tip : steps.tips) {
      EXPECT_EQ(tip.source, DistanceSource::none) << scene.name;
      EXPECT_TRUE(std::isnan(tip.to_rpe_um)) << scene.name;
    }
    if (steps.tips.size() == whole.tips.size()) {
      ++located_early;
      EXPECT_EQ(steps.mask, whole.mask) << scene.name;
      for (std::size_t i = 0; i < steps.tips.size(); ++i) {
        gpu::instruments::InstrumentTip without = whole.tips[i];
        without.ilm_px = without.rpe_px = without.to_ilm_um = without.to_rpe_um =
            gpu::instruments::InstrumentTip::kNone;
        without.source = DistanceSource::none;
        expect_same_tip(steps.tips[i], without, scene.name + " (located)");
      }
    } else {
      EXPECT_TRUE(steps.tips.empty()) << scene.name << ": a paddle waits with every tip";
      EXPECT_EQ(scene.kind, sim::InstrumentKind::scraper) << scene.name;
      ++paddles_waiting;
    }
    detector->end_group(surfaces, steps);
    EXPECT_EQ(steps.columns, whole.columns) << scene.name;
    EXPECT_EQ(steps.mask, whole.mask) << scene.name;
    EXPECT_EQ(steps.nearest, whole.nearest) << scene.name;
    EXPECT_EQ(steps.warning, whole.warning) << scene.name;
    ASSERT_EQ(steps.tips.size(), whole.tips.size()) << scene.name;
    for (std::size_t i = 0; i < steps.tips.size(); ++i) {
      expect_same_tip(steps.tips[i], whole.tips[i], scene.name);
    }

    // Misuse: nothing begun, twice, other findings. A group dropped once located has no tips.
    EXPECT_THROW(detector->locate_tips(steps), std::logic_error) << scene.name;
    detector->begin_group(ref, {0, 16}, steps);
    InstrumentFindings other;
    EXPECT_THROW(detector->locate_tips(other), std::logic_error) << scene.name;
    detector->locate_tips(steps);
    EXPECT_THROW(detector->locate_tips(steps), std::logic_error) << scene.name;
    detector->drop_group();
    EXPECT_TRUE(steps.tips.empty()) << scene.name;
    EXPECT_EQ(steps.nearest, -1) << scene.name;
    EXPECT_THROW(detector->end_group(surfaces, steps), std::logic_error) << scene.name;
  }
  // Both ways through the two halves were taken.
  EXPECT_GT(located_early, 0u);
  EXPECT_GT(paddles_waiting, 0u);
}

// The whole field of the default raster (512 x 128), tools as ioct-rt's --sim-instrument poses
// them, segmented and searched on the CPU as ioct-gpu does live.
InstrumentFindings find_in_field(const std::vector<const char*>& specs, SceneVolume& s) {
  std::vector<sim::InstrumentConfig> tools;
  for (const char* spec : specs) tools.push_back(sim::parse_instrument_spec(spec, "test"));
  s = make_field_volume(tools, 512, 128);
  return detect(s);
}

// The appliance's forceps scene (tools/ioct-demo --forceps): the pitched shaft rises out of the
// top of the image towards the field's edge, where only its shadow's edges stay classified and a
// stretch of one came apart from the rest (12 A-scans, once reported as a second instrument). The
// demo moves the forceps between depths 0.44 and 0.54 of the axis (from 400 um above the ILM to
// 17 um above it); at both ends and in the middle: one tool, its tip within the 2 voxels
// (0.38 at 0.49; 2.92 there while a partly shadowed A-scan of the retina ahead of the tip counted
// as the end's rim) and its distances within 15 um (ILM 9.9-10.1, RPE 2.4-2.7 um; the ILM's was
// 19.9 um at 0.49 while the surfaces under the shaft's wide shadow, on the fovea's slope, were
// interpolated by lines: README.md).
TEST(InstrumentAccuracy, TheAppliancesForcepsIsOneToolThePiecesOfItsShaftIncluded) {
  for (const char* spec : {"forceps:x=0.15,y=0,depth=0.44,yaw=200,pitch=20",
                           "forceps:x=0.15,y=0,depth=0.49,yaw=200,pitch=20",
                           "forceps:x=0.15,y=0,depth=0.54,yaw=200,pitch=20"}) {
    SCOPED_TRACE(spec);
    SceneVolume s;
    const InstrumentFindings findings = find_in_field({spec}, s);
    ASSERT_EQ(findings.tips.size(), 1u) << describe(findings);
    const auto& tip = findings.tips[0];
    const double error = tip_error_vox(tip, s.tip);
    std::printf(
        "[ figures  ] the appliance's forceps, %s: tip (%.1f %.1f %.1f) truth (%.1f %.1f %.1f) "
        "vox: error %.2f; ILM %+.1f (truth %+.1f) RPE %+.1f (truth %+.1f) um\n",
        spec, tip.bscan, tip.ascan, tip.depth_px, s.tip.bscan, s.tip.ascan, s.tip.depth_px, error,
        tip.to_ilm_um, s.to_ilm_um, tip.to_rpe_um, s.to_rpe_um);
    EXPECT_LE(error, kTipP95Vox);
    EXPECT_LE(std::abs(tip.to_ilm_um - s.to_ilm_um), kIlmDistanceP95Um);
    EXPECT_LE(std::abs(tip.to_rpe_um - s.to_rpe_um), kIlmDistanceP95Um);
  }
}

// Two tools: the appliance's forceps and a needle entering the field far behind the forceps' end,
// 2.6 mm beside its shaft, its footprint small enough (under an eighth of the forceps') to be
// tried as a piece of that shaft: it is a tool of its own, its tip where the simulator put it.
TEST(InstrumentAccuracy, ASmallToolBesideAnotherToolsShaftStaysATool) {
  SceneVolume s;
  const InstrumentFindings findings =
      find_in_field({"forceps:x=0.15,y=0,depth=0.49,yaw=200,pitch=20",
                     "needle:x=-0.85,y=0.5,depth=0.45,yaw=180,pitch=20"},
                    s);
  ASSERT_EQ(findings.tips.size(), 2u) << describe(findings);
  ASSERT_EQ(s.tool_tips.size(), 2u);
  // Largest footprint first: the forceps, then the needle.
  EXPECT_LT(findings.tips[1].footprint_ascans * 8, findings.tips[0].footprint_ascans);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& tip = findings.tips[i];
    const double error = tip_error_vox(tip, s.tool_tips[i]);
    std::printf("[ figures  ] tool %zu (%u A-scans): tip error %.2f vox\n", i, tip.footprint_ascans,
                error);
    EXPECT_LE(error, kTipP95Vox) << "tool " << i;
  }
}

// No tool, and what might pass for one: a lifted epiretinal membrane (a thin bright line above the
// retina, over a gap) and a macular hole (the retina missing, its cuff's cysts dark). Nothing is
// reported.
TEST(InstrumentAccuracy, RetinasWithoutToolsHaveNone) {
  for (const bool membrane : {false, true}) {
    seg_test::SimulatedVolumeSpec spec;
    spec.ascans = 256;
    spec.bscans = 32;
    spec.filter = false;
    spec.simulation.scan.extent_x = 255.0f / 511.0f;
    spec.simulation.scan.extent_y = 31.0f / 127.0f;
    if (membrane) {
      spec.simulation.retina.membrane.enabled = true;
      spec.simulation.scan.center_x = -0.35f;
      spec.simulation.scan.center_y = 0.2f;
    } else {
      spec.simulation.retina.macular_hole.enabled = true;
    }
    const seg_test::SimulatedVolume v = seg_test::make_simulated_volume(spec);
    gpu::segmentation::VolumeSampling sampling;
    sampling.axial_um_per_px = v.axial_um_per_px;
    InstrumentFindings findings;
    gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, sampling, 2)
        ->detect_volume(v.volume, {}, findings);
    std::size_t masked = 0;
    std::size_t classified = 0;
    for (std::size_t k = 0; k < findings.size(); ++k) {
      masked += findings.mask[k] != gpu::instruments::ColumnKind::clear ? 1 : 0;
      classified += findings.columns[k] != gpu::instruments::ColumnKind::clear ? 1 : 0;
    }
    std::printf(
        "[ figures  ] %s: %zu of %zu A-scans classified as a tool's on their own, %zu "
        "masked, %zu instruments\n",
        membrane ? "membrane" : "macular hole", classified, findings.size(), masked,
        findings.tips.size());
    EXPECT_TRUE(findings.tips.empty())
        << (membrane ? "membrane: " : "macular hole: ") << describe(findings);
  }
}

}  // namespace
}  // namespace ioct::instruments_test
