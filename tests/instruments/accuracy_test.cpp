// Accuracy against the simulator's ground truth over the instrument scenes: each scene's volume
// through the CPU chain and the volume filters, segmented and searched for instruments on the
// CPU, as ioct-gpu does live. Over all scenes: the tip within 2 voxels (p95, Euclidean over
// B-scan, A-scan and depth index) of the pose's tip, and the tip-to-ILM and tip-to-RPE distances
// within 15 um (p95) of the truth. The figures are printed ("[ figures ]") for README.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

namespace ioct::instruments_test {
namespace {

using gpu::instruments::DistanceSource;
using gpu::instruments::InstrumentFindings;

double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t k = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(v.size()))) - 1;
  return v[std::min(k, v.size() - 1)];
}

TEST(InstrumentAccuracy, TipWithinTwoVoxelsAndDistancesWithin15UmP95) {
  std::vector<double> tip_errors, ilm_errors, rpe_errors;
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    gpu::segmentation::Surfaces surfaces;
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
    InstrumentFindings findings;
    gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2)
        ->detect_volume(s.volume.volume, surfaces, findings);
    ASSERT_NE(findings.nearest_tip(), nullptr) << scene.name << ": no instrument found";
    const auto& tip = *findings.nearest_tip();
    const double db = tip.bscan - s.tip.bscan, da = tip.ascan - s.tip.ascan,
                 dz = tip.depth_px - s.tip.depth_px;
    const double error = std::sqrt(db * db + da * da + dz * dz);
    tip_errors.push_back(error);
    ilm_errors.push_back(std::abs(tip.to_ilm_um - s.to_ilm_um));
    rpe_errors.push_back(std::abs(tip.to_rpe_um - s.to_rpe_um));
    std::printf(
        "[ figures  ] %-26s tip (%.1f %.1f %.1f) truth (%.1f %.1f %.1f) err %.2f vox; ILM %+.1f "
        "(truth %+.1f) RPE %+.1f (truth %+.1f) um, %s, %zu found\n",
        scene.name.c_str(), tip.bscan, tip.ascan, tip.depth_px, s.tip.bscan, s.tip.ascan,
        s.tip.depth_px, error, tip.to_ilm_um, s.to_ilm_um, tip.to_rpe_um, s.to_rpe_um,
        std::string(to_string(tip.source)).c_str(), findings.tips.size());
    EXPECT_NE(tip.source, DistanceSource::none) << scene.name;
  }
  const double tip_p95 = p95(tip_errors), ilm_p95 = p95(ilm_errors), rpe_p95 = p95(rpe_errors);
  std::printf("[ figures  ] over %zu scenes: tip p95 %.2f vox, ILM distance p95 %.1f um, RPE "
              "distance p95 %.1f um\n",
              tip_errors.size(), tip_p95, ilm_p95, rpe_p95);
  RecordProperty("tip_p95_vox", std::to_string(tip_p95));
  RecordProperty("ilm_p95_um", std::to_string(ilm_p95));
  RecordProperty("rpe_p95_um", std::to_string(rpe_p95));
  EXPECT_LE(tip_p95, 2.0);
  EXPECT_LE(ilm_p95, 15.0);
  EXPECT_LE(rpe_p95, 15.0);
}

}  // namespace
}  // namespace ioct::instruments_test
