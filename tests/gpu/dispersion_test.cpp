// Dispersion compensation: a dispersed reflector is blurred; the right c2, c3 make it as sharp
// as an undispersed one, and the estimator finds them from the data alone.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "ioct/gpu/cpu_oct_processor.hpp"
#include "ioct/gpu/dispersion_estimator.hpp"
#include "processing_fixture.hpp"

namespace ioct::gpu {
namespace {

using testing::Reflector;

constexpr double kC2 = 40.0;  // radians at the sweep's ends: a few mm of glass mismatch
constexpr double kC3 = -12.0;

struct Group {
  shm::RingGeometry geometry;
  std::vector<std::uint16_t> payload;
  shm::SlotHeader header{};
};

// Layers at three depths in every A-scan, dispersed by (c2, c3).
Group dispersed_group(double c2, double c3) {
  Group g;
  g.geometry.samples_per_ascan = 1024;
  g.geometry.ascans_per_bscan = 32;
  g.geometry.bscans_per_group = 4;
  g.geometry.bscans_per_volume = 4;
  testing::SpectrumModel model{.samples = 1024, .noise_sigma = 2.0};
  model.c2 = c2;
  model.c3 = c3;
  testing::SpectrumSynthesizer synthesizer(model, 11);
  g.payload.resize(g.geometry.group_payload_bytes() / 2);
  testing::fill_group(
      g.geometry, synthesizer,
      [](std::uint32_t b, std::uint32_t a) {
        return std::vector<Reflector>{{120.0 + b * 3 + a % 5, 30.0}, {300.0, 15.0}, {420.0, 25.0}};
      },
      g.payload);
  g.header = testing::header_for(g.geometry, 0, g.geometry.ascans_per_bscan);
  return g;
}

struct Sharpness {
  double width = 0.0;  // mean width of the layer at 420 px, 6 levels below its peak
  double peak = 0.0;   // mean u8 at that peak
  double depth_error = 0.0;
};

Sharpness measure(const Group& g, double c2, double c3) {
  OctProcessorConfig config = testing::quick_config();
  config.dispersion = {c2, c3};
  CpuOctProcessor processor(config);
  processor.prepare(g.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{g.header, g.payload}, out);
  Sharpness s;
  const double n = static_cast<double>(out.bscan_count * out.ascans);
  for (std::uint32_t b = 0; b < out.bscan_count; ++b) {
    for (std::uint32_t a = 0; a < out.ascans; ++a) {
      const auto layer = testing::ascan_of(out, b, a).subspan(380, 80);  // 420 px +-40
      const std::uint32_t peak = testing::brightest_depth(layer);
      s.width += testing::peak_width(layer, 6) / n;
      s.peak += layer[peak] / n;
      s.depth_error += std::abs(380.0 + peak - 420.0) / n;
    }
  }
  return s;
}

TEST(Dispersion, TheRightCorrectionMakesADispersedLayerAsSharpAsAnUndispersedOne) {
  const Sharpness reference = measure(dispersed_group(0.0, 0.0), 0.0, 0.0);
  const Group dispersed = dispersed_group(kC2, kC3);
  const Sharpness blurred = measure(dispersed, 0.0, 0.0);
  const Sharpness corrected = measure(dispersed, kC2, kC3);
  const Sharpness wrong_sign = measure(dispersed, -kC2, -kC3);
  EXPECT_GT(blurred.width, 3.0 * reference.width);
  EXPECT_LT(blurred.peak, reference.peak - 30.0);
  EXPECT_LT(corrected.width, reference.width + 1.0);
  EXPECT_GT(corrected.peak, reference.peak - 3.0);
  EXPECT_LT(corrected.depth_error, 0.5);
  // The sign convention is the one documented: exp(-i phi) undoes a phase of +phi.
  EXPECT_GT(wrong_sign.width, blurred.width);
  // An undispersed group is not changed by the complex path beyond rounding.
  const Sharpness reference_complex = measure(dispersed_group(0.0, 0.0), 1e-9, 0.0);
  EXPECT_NEAR(reference_complex.peak, reference.peak, 0.5);
}

TEST(Dispersion, TheEstimatorFindsC2AndC3FromTheData) {
  const Group dispersed = dispersed_group(kC2, kC3);
  OctProcessorConfig processing = testing::quick_config();
  DispersionSearch search;
  search.ascans = 64;
  DispersionEstimator estimator(processing, search);
  estimator.load(dispersed.geometry, RawGroup{dispersed.header, dispersed.payload});
  const DispersionEstimate e = estimator.estimate();
  EXPECT_NEAR(e.c2, kC2, 2.0);
  EXPECT_NEAR(e.c3, kC3, 2.0);
  EXPECT_GT(e.sharpness, 3.0 * e.sharpness_uncompensated);
  EXPECT_EQ(e.ascans_used, 64u);
  // The metric is highest near the truth.
  EXPECT_GT(estimator.sharpness(kC2, kC3), estimator.sharpness(kC2 + 10.0, kC3));
  EXPECT_GT(estimator.sharpness(kC2, kC3), estimator.sharpness(kC2, kC3 + 10.0));

  // An undispersed group needs no correction.
  const Group clean = dispersed_group(0.0, 0.0);
  estimator.load(clean.geometry, RawGroup{clean.header, clean.payload});
  const DispersionEstimate none = estimator.estimate();
  EXPECT_NEAR(none.c2, 0.0, 2.0);
  EXPECT_NEAR(none.c3, 0.0, 2.0);
}

}  // namespace
}  // namespace ioct::gpu
