#include <gtest/gtest.h>
#include <cstdio>
#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
namespace ioct::instruments_test {
TEST(Debug, Dump) {
  const SceneVolume s = make_scene_volume(instrument_scenes()[0]);
  const auto& v = s.volume.volume;
  auto dump = [&](std::uint32_t b, std::uint32_t a) {
    std::printf("b%u a%u tool %.1f ilm %.1f:", b, a, s.volume.tool_truth[b * 128 + a], s.volume.ilm_truth[b*128+a]);
    for (std::uint32_t d = 240; d < 500; d += 2) std::printf(" %d", v.at(b, a, d));
    std::printf("\n");
  };
  dump(0, 27); dump(14, 60); dump(14, 80); dump(16, 80); dump(18,80); dump(8, 46);
  for (auto& scene : instrument_scenes()) {
  const SceneVolume s = make_scene_volume(scene);
  const auto& v = s.volume.volume;
  gpu::instruments::InstrumentFindings f;
  gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2)->detect_volume(v, {}, f);
  std::printf("%s\n", scene.name.c_str());
  for (std::uint32_t b = 0; b < v.bscans(); b += 2) {
    for (std::uint32_t a = 0; a < v.ascans(); ++a) {
      const auto k = f.index(b, a);
      const bool truth = !std::isnan(s.volume.tool_truth[k]);
      std::printf("%c", "._p"[int(f.mask[k])] - (truth && f.mask[k]==gpu::instruments::ColumnKind::clear ? ('.' - '-') : 0));
    }
    std::printf("\n");
  }
  }
}
}
