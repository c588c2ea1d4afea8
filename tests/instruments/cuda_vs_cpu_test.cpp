// The CUDA instrument detection against the CPU reference on the instrument scenes: the same
// floors, the same classification of every A-scan and bit-identical reflexes (the column code is
// the same integer arithmetic on both, the parabola the same float expression without fused
// multiply-add), hence the same tips. Skipped, saying why, where the CUDA detection cannot run.
#include <gtest/gtest.h>

#include <cstring>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

namespace ioct::instruments_test {
namespace {

using gpu::instruments::InstrumentFindings;

TEST(InstrumentsCudaVsCpu, SameMaskReflexesAndTipsGroupByGroup) {
  try {
    gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, {}, 1);
  } catch (const gpu::BackendUnavailable& e) {
    GTEST_SKIP() << "CUDA instrument detection not tested: " << e.what();
  }
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    const auto cuda =
        gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, s.sampling, 1);
    gpu::segmentation::Surfaces surfaces;
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
    const auto cpu =
        gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2);
    InstrumentFindings a, b;
    // Group by group, as live: 16 B-scans at a time.
    for (std::uint32_t first = 0; first < s.volume.volume.bscans(); first += 16) {
      cpu->detect_group(s.volume.volume, {first, 16}, surfaces, a);
      cuda->detect_group(s.volume.volume, {first, 16}, surfaces, b);
    }
    ASSERT_EQ(a.floor, b.floor) << scene.name;
    ASSERT_EQ(a.columns, b.columns) << scene.name;
    ASSERT_EQ(
        0, std::memcmp(a.reflex_px.data(), b.reflex_px.data(), a.reflex_px.size() * sizeof(float)))
        << scene.name;
    ASSERT_EQ(a.tips.size(), b.tips.size()) << scene.name;
    for (std::size_t i = 0; i < a.tips.size(); ++i) {
      EXPECT_EQ(a.tips[i].ascan, b.tips[i].ascan) << scene.name;
      EXPECT_EQ(a.tips[i].depth_px, b.tips[i].depth_px) << scene.name;
      EXPECT_EQ(a.tips[i].to_rpe_um, b.tips[i].to_rpe_um) << scene.name;
    }
  }
}

}  // namespace
}  // namespace ioct::instruments_test
