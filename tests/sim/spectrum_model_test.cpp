// The pieces under the simulated digitizer: the source's depth scale and envelope, the fringe
// tables' sub-bin depths, and the retina's shape.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ioct/sim/fringe_tables.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/spectrum_synthesizer.hpp"
#include "ioct/sim/swept_source.hpp"
#include "spectrum_fft.hpp"

namespace ioct::sim {
namespace {

TEST(SweptSource, AxialPixelFollowsTheSweepBandwidth) {
  SweptSourceConfig source;  // 1060 nm, 100 nm
  // The textbook approximation lambda0^2 / (2 delta lambda) = 5.618 um.
  EXPECT_NEAR(source.axial_pixel_um(), 1.060 * 1.060 / (2 * 0.100), 0.02);
  source.sweep_bandwidth_nm = 50.0;
  EXPECT_NEAR(source.axial_pixel_um(), 1.060 * 1.060 / (2 * 0.050), 0.03);
}

TEST(SweptSource, EnvelopeIsAGaussianOfTheConfiguredWidth) {
  const SweptSourceConfig source;  // 70 nm FWHM of a 100 nm sweep
  const std::vector<float> envelope = source.envelope(1376);
  const auto peak = std::max_element(envelope.begin(), envelope.end());
  EXPECT_NEAR(*peak, 1.0f, 1e-3f);
  // Samples are even in k = 2 pi / lambda, so 1060 nm lies at 47.6% of a 1010-1110 nm sweep.
  const double centre = 1376.0 * (1 / 1060.0 - 1 / 1110.0) / (1 / 1010.0 - 1 / 1110.0);
  EXPECT_NEAR(static_cast<double>(peak - envelope.begin()), centre, 1.0);
  const auto above_half =
      std::count_if(envelope.begin(), envelope.end(), [](float v) { return v >= 0.5f; });
  EXPECT_NEAR(static_cast<double>(above_half), 1376.0 * 70.0 / 100.0, 15.0);
}

TEST(FringeTables, ResolvesDepthsToSixteenthsOfABin) {
  EXPECT_EQ(FringeTables::resolve(10.03f).bin, 10u);
  EXPECT_EQ(FringeTables::resolve(10.03f).fraction, 0u);
  EXPECT_EQ(FringeTables::resolve(10.5f).bin, 10u);
  EXPECT_EQ(FringeTables::resolve(10.5f).fraction, 8u);
  EXPECT_EQ(FringeTables::resolve(10.98f).bin, 11u);
  EXPECT_EQ(FringeTables::resolve(10.98f).fraction, 0u);
  EXPECT_FLOAT_EQ(FringeTables::depth_px({3, 4}), 3.25f);
}

// One noiseless reflector on an empty detector: the FFT peak sits at its depth, to a fraction
// of a bin (the fractional tables, not just whole bins).
TEST(SpectrumSynthesizer, SingleReflectorPeaksAtItsSubBinDepth) {
  DetectorConfig quiet;
  quiet.reference_dc_counts = 0.0;
  quiet.fixed_pattern_counts = 0.0;
  quiet.read_noise_counts = 0.0;
  quiet.shot_noise_counts = 0.0;
  const std::uint32_t samples = 1376;
  SpectrumSynthesizer synthesizer(SweptSourceConfig{}, quiet, samples, 12, 1);
  test::SpectrumFft fft(samples);
  std::vector<std::uint16_t> spectrum(samples);
  for (const float depth : {100.25f, 100.75f, 411.5f, 640.0625f}) {
    SCOPED_TRACE(depth);
    const Reflector reflector{FringeTables::resolve(depth), 400.0f};
    synthesizer.synthesize({&reflector, 1}, 0, 0, spectrum.data());
    const auto magnitude = fft.magnitude(spectrum);
    const auto peak = static_cast<std::uint32_t>(
        std::max_element(magnitude.begin(), magnitude.end()) - magnitude.begin());
    EXPECT_NEAR(static_cast<float>(peak), depth, 0.5f);
    EXPECT_NEAR(test::interpolated_peak(magnitude, peak), depth, 0.1);
  }
}

TEST(SpectrumSynthesizer, NoiseHasTheConfiguredLevel) {
  DetectorConfig noisy;
  noisy.reference_dc_counts = 0.0;
  noisy.fixed_pattern_counts = 0.0;
  noisy.read_noise_counts = 20.0;
  noisy.shot_noise_counts = 0.0;
  const std::uint32_t samples = 1376;
  SpectrumSynthesizer synthesizer(SweptSourceConfig{}, noisy, samples, 12, 3);
  std::vector<std::uint16_t> spectrum(samples);
  double sum = 0.0;
  double sum_squares = 0.0;
  double count = 0.0;
  for (std::uint32_t offset = 0; offset < 64; ++offset) {
    synthesizer.synthesize({}, offset * 1000, offset * 997 + 5, spectrum.data());
    for (const std::uint16_t value : spectrum) {
      sum += value;
      sum_squares += static_cast<double>(value) * value;
      count += 1.0;
    }
  }
  const double mean = sum / count;
  const double sigma = std::sqrt(sum_squares / count - mean * mean);
  EXPECT_NEAR(mean, 2048.0, 0.5);
  EXPECT_NEAR(sigma, 20.0, 1.0);  // rounding to counts adds 1/12 count^2
}

class RetinaModelTest : public testing::Test {
 protected:
  static constexpr std::uint32_t kDepthBins = 688;
  const SweptSourceConfig source_;
  const RetinaConfig config_;
  const RetinaModel model_{config_, source_.axial_pixel_um(), kDepthBins};

  float depth(hal::BeamPosition beam, RetinalInterface interface) const {
    return model_.column(beam)[static_cast<std::size_t>(interface)].depth_px;
  }
  // ILM to RPE, physical micrometres.
  double thickness_um(hal::BeamPosition beam) const {
    const double px = depth(beam, RetinalInterface::rpe) - depth(beam, RetinalInterface::ilm);
    return px * source_.axial_pixel_um() / config_.tissue_index;
  }
};

TEST_F(RetinaModelTest, InterfacesKeepTheirOrderEverywhere) {
  for (float y = -1.0f; y <= 1.0f; y += 0.125f) {
    for (float x = -1.0f; x <= 1.0f; x += 0.125f) {
      const RetinaColumn column = model_.column({x, y});
      for (std::size_t i = 1; i < column.size(); ++i) {
        EXPECT_LE(column[i - 1].depth_px, column[i].depth_px) << x << ", " << y << " #" << i;
      }
      EXPECT_GE(column.front().depth_px, 0.0f);
      EXPECT_LT(column.back().depth_px, static_cast<float>(kDepthBins));
    }
  }
}

TEST_F(RetinaModelTest, ParafovealRetinaIsAbout300UmThickAndThePitHalvesIt) {
  const hal::BeamPosition fovea{static_cast<float>(config_.fovea_x),
                                static_cast<float>(config_.fovea_y)};
  const hal::BeamPosition parafovea{0.7f, 0.0f};
  EXPECT_NEAR(thickness_um(parafovea), 295.0, 10.0);
  EXPECT_LT(thickness_um(fovea), 0.6 * thickness_um(parafovea));
  EXPECT_GT(thickness_um(fovea), 0.35 * thickness_um(parafovea));
  // The inner layers' interfaces fade into the pit; the ILM, IS/OS and RPE stay.
  const RetinaColumn pit = model_.column(fovea);
  EXPECT_LT(pit[static_cast<std::size_t>(RetinalInterface::ipl_inl)].reflectivity, 0.1f);
  EXPECT_GT(pit[static_cast<std::size_t>(RetinalInterface::ilm)].reflectivity, 0.5f);
  EXPECT_EQ(pit[static_cast<std::size_t>(RetinalInterface::rpe)].reflectivity, 1.0f);
}

TEST_F(RetinaModelTest, TheFundusCurvesTowardsTheViewerAtTheEdges) {
  const float center = depth({0.0f, 0.0f}, RetinalInterface::rpe);
  const float edges = 0.5f * (depth({-1.0f, 0.0f}, RetinalInterface::rpe) +
                              depth({1.0f, 0.0f}, RetinalInterface::rpe));
  EXPECT_NEAR(center - edges, config_.curvature_fraction * kDepthBins, 0.5);
  EXPECT_GT(center - edges, 10.0f);
}

}  // namespace
}  // namespace ioct::sim
