// The pieces under the simulated digitizer: the source's depth scale, spectral shapes and
// sampling (with the calibration polynomial), the FFT synthesis, and the samples' geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "ioct/sim/anterior_segment_model.hpp"
#include "ioct/sim/instrument_model.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/spectral_sampling.hpp"
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

TEST(SweptSource, GaussianEnvelopeHasTheConfiguredWidth) {
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

TEST(SweptSource, SuperGaussianIsFlatterAndTabulatedFollowsItsPoints) {
  SweptSourceConfig gaussian;
  SweptSourceConfig flat = gaussian;
  flat.shape = SpectralShape::super_gaussian;
  flat.super_gaussian_order = 8.0;
  const std::vector<float> g = gaussian.envelope(1000);
  const std::vector<float> f = flat.envelope(1000);
  const auto count_above = [](const std::vector<float>& e, float level) {
    return std::count_if(e.begin(), e.end(), [level](float v) { return v >= level; });
  };
  // Same half width, but a flatter top and steeper edges.
  EXPECT_NEAR(static_cast<double>(count_above(f, 0.5f)), static_cast<double>(count_above(g, 0.5f)),
              10.0);
  EXPECT_GT(count_above(f, 0.9f), count_above(g, 0.9f) + 150);
  EXPECT_LT(count_above(f, 0.02f), count_above(g, 0.02f));

  SweptSourceConfig measured;
  measured.shape = SpectralShape::tabulated;
  measured.tabulated = {{1000.0, 0.0}, {1040.0, 2.0}, {1080.0, 4.0}, {1120.0, 0.0}};
  ASSERT_NO_THROW(measured.validate());
  const double k = [](double nm) { return 2.0 * std::numbers::pi / (nm * 1e-3); }(1060.0);
  EXPECT_NEAR(measured.power_at_k(k), 0.75, 1e-9);  // halfway between 0.5 and 1 (peak 4 -> 1)
  EXPECT_EQ(measured.power_at_k(2.0 * std::numbers::pi / 1.2), 0.0);  // 1200 nm: outside
}

TEST(SweptSource, RolloffIsHalfAmplitudeAtTheConfiguredDepth) {
  SweptSourceConfig source;
  EXPECT_DOUBLE_EQ(source.rolloff_at_mm(0.0), 1.0);
  EXPECT_NEAR(source.rolloff_at_mm(3.9), 0.5, 1e-12);
  EXPECT_NEAR(20.0 * std::log10(source.rolloff_at_mm(3.9)), -6.02, 0.01);
  source.rolloff_6db_depth_mm = 0.0;
  EXPECT_DOUBLE_EQ(source.rolloff_at_mm(3.9), 1.0);
}

TEST(SpectralSampling, KClockIsTheIdentityAndLambdaLinearHasAnAccurateCalibration) {
  const SweptSourceConfig source;
  const std::uint32_t n = 1376;
  const SpectralSampling k_clock = spectral_sampling(source, hal::ClockSource::external_k_clock, n);
  EXPECT_EQ(k_clock.calibration.coefficients, (std::vector<double>{0.0, 1.0}));
  EXPECT_TRUE(k_clock.k_linear);
  EXPECT_DOUBLE_EQ(k_clock.k_index[700], 700.0);

  const SpectralSampling internal = spectral_sampling(source, hal::ClockSource::internal, n);
  EXPECT_FALSE(internal.k_linear);
  // Same first and last k as the k-clock, evenly spaced in wavelength between them.
  EXPECT_NEAR(internal.k_index.front(), 0.0, 1e-9);
  EXPECT_NEAR(internal.k_index.back(), n - 1.0, 1e-9);
  const double dl0 = internal.wavelength_nm[1] - internal.wavelength_nm[0];
  const double dl1 = internal.wavelength_nm[n - 1] - internal.wavelength_nm[n - 2];
  EXPECT_NEAR(dl0, dl1, 1e-9);
  EXPECT_LT(dl0, 0.0);  // k increases with the sample index, so lambda decreases
  // Samples are denser in k at the long-wavelength end: k_index bends.
  EXPECT_GT(std::abs(internal.k_index[n / 2] - n / 2.0), 10.0);
  // The calibration (gpu/ convention: raw position of k-linear sample j) inverts k_index.
  EXPECT_LT(internal.calibration.max_error_samples, 0.01);
  EXPECT_EQ(internal.calibration.coefficients.size(), kCalibrationDegree + 1);
  for (const std::uint32_t i : {0u, 100u, 688u, 1200u, n - 1}) {
    EXPECT_NEAR(internal.calibration.raw_position(n, internal.k_index[i]), i, 0.01) << i;
  }
  // Evaluated by the same formula gpu/ uses: x(j) = (N - 1) sum c_n t^n.
  const double j = 900.0;
  const double t = j / (n - 1);
  double x = 0.0;
  for (std::size_t p = internal.calibration.coefficients.size(); p-- > 0;) {
    x = x * t + internal.calibration.coefficients[p];
  }
  EXPECT_NEAR((n - 1) * x, internal.calibration.raw_position(n, j), 1e-9);
}

SynthesisSetup quiet_setup(std::uint32_t samples) {
  SynthesisSetup setup;
  setup.detector.reference_dc_counts = 0.0;
  setup.detector.fixed_pattern_counts = 0.0;
  setup.detector.read_noise_counts = 0.0;
  setup.detector.shot_noise_counts = 0.0;
  setup.detector.rin_counts = 0.0;
  setup.detector.sweep_power_jitter = 0.0;
  setup.source.rolloff_6db_depth_mm = 0.0;
  setup.samples = samples;
  return setup;
}

// One noiseless reflector: the FFT peak sits at the depth the profile says it drew it at.
TEST(SpectrumSynthesizer, SingleReflectorPeaksWhereTheProfileDrewIt) {
  const std::uint32_t samples = 1376;
  SpectrumSynthesizer synthesizer(quiet_setup(samples));
  EXPECT_EQ(synthesizer.fft_points(), 2048u);  // the smallest power of two >= 1.4 N
  test::SpectrumFft fft(samples);
  std::vector<std::uint16_t> spectrum(samples);
  for (const float depth : {100.25f, 100.75f, 411.5f, 640.1f}) {
    SCOPED_TRACE(depth);
    DepthProfile& profile = synthesizer.profile();
    profile.begin_column(1);
    profile.add_reflector_with_phase(depth, 5.0f, 0.3f);
    const float drawn = profile.drawn_depth(depth);
    EXPECT_LE(std::abs(drawn - depth),
              0.5 * samples / static_cast<double>(synthesizer.fft_points()) + 1e-4);
    synthesizer.synthesize({}, true, spectrum.data());
    const auto magnitude = fft.magnitude(spectrum);
    const auto peak = static_cast<std::uint32_t>(
        std::max_element(magnitude.begin(), magnitude.end()) - magnitude.begin());
    EXPECT_NEAR(static_cast<float>(peak), drawn, 0.5f);
    EXPECT_NEAR(test::interpolated_peak(magnitude, peak), drawn, 0.1);
  }
}

TEST(SpectrumSynthesizer, ProfileIsClearedAfterEachSpectrum) {
  const std::uint32_t samples = 512;
  SpectrumSynthesizer synthesizer(quiet_setup(samples));
  std::vector<std::uint16_t> first(samples);
  std::vector<std::uint16_t> empty(samples);
  synthesizer.profile().begin_column(7);
  synthesizer.profile().add_scatter(50.0f, 80.0f, 3.0f, 0.01f);
  synthesizer.synthesize({}, true, first.data());
  synthesizer.profile().begin_column(7);
  synthesizer.synthesize({}, true, empty.data());
  EXPECT_NE(first, empty);
  const std::uint16_t offset = 2048;
  EXPECT_TRUE(std::all_of(empty.begin(), empty.end(), [&](auto v) { return v == offset; }));
}

TEST(SpectrumSynthesizer, ScatterHasTheIntensityPerPxItWasGiven) {
  // Fully developed speckle from a layer of amplitude a per px: the mean power of its bins is
  // independent of the grid; compare two amplitudes.
  const std::uint32_t samples = 1024;
  SpectrumSynthesizer synthesizer(quiet_setup(samples));
  test::SpectrumFft fft(samples);
  std::vector<std::uint16_t> spectrum(samples);
  const auto mean_power = [&](float amplitude) {
    double power = 0.0;
    for (std::uint64_t column = 0; column < 200; ++column) {
      synthesizer.profile().begin_column(column);
      synthesizer.profile().add_scatter(100.0f, 300.0f, amplitude, 0.0f);
      synthesizer.synthesize({}, true, spectrum.data());
      const auto magnitude = fft.magnitude(spectrum);
      for (std::uint32_t bin = 150; bin < 250; ++bin) power += magnitude[bin] * magnitude[bin];
    }
    return power;
  };
  EXPECT_NEAR(mean_power(2.0f) / mean_power(1.0f), 4.0, 0.4);
}

TEST(SpectrumSynthesizer, NoiseHasTheConfiguredLevel) {
  SynthesisSetup setup = quiet_setup(1376);
  setup.detector.read_noise_counts = 20.0;
  SpectrumSynthesizer synthesizer(setup);
  std::vector<std::uint16_t> spectrum(1376);
  double sum = 0.0;
  double sum_squares = 0.0;
  double count = 0.0;
  for (std::uint32_t offset = 0; offset < 64; ++offset) {
    synthesizer.synthesize({offset * 1000, offset * 997 + 5, 1.0f}, true, spectrum.data());
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

TEST(SpectrumSynthesizer, NoLightLeavesOnlyTheOffsetAndReadNoise) {
  SynthesisSetup setup;  // reference DC, fringes, shot noise...
  setup.samples = 512;
  setup.detector.read_noise_counts = 0.0;
  SpectrumSynthesizer synthesizer(setup);
  std::vector<std::uint16_t> spectrum(512);
  synthesizer.profile().begin_column(3);
  synthesizer.profile().add_reflector(100.0f, 10.0f, 3);
  synthesizer.synthesize({1, 2, 1.0f}, false, spectrum.data());
  EXPECT_TRUE(std::all_of(spectrum.begin(), spectrum.end(), [](auto v) { return v == 2048; }));
}

class RetinaModelTest : public testing::Test {
 protected:
  static constexpr std::uint32_t kDepthBins = 688;
  const SweptSourceConfig source_;
  const RetinaConfig config_;
  const RetinaModel model_{config_, source_.axial_pixel_um(), kDepthBins};

  double thickness_um(const RetinaModel& model, hal::BeamPosition beam) const {
    const RetinaColumn c = model.column(beam);
    return (c.rpe_px - c.ilm_px) * model.tissue_um_per_px();
  }
};

TEST_F(RetinaModelTest, LayersKeepTheirOrderEverywhere) {
  for (float y = -1.0f; y <= 1.0f; y += 0.125f) {
    for (float x = -1.0f; x <= 1.0f; x += 0.125f) {
      const RetinaColumn column = model_.column({x, y});
      for (std::size_t i = 1; i < column.top.size(); ++i) {
        EXPECT_LE(column.top[i - 1], column.top[i]) << x << ", " << y << " #" << i;
      }
      EXPECT_GE(column.ilm_px, 0.0f);
      EXPECT_GT(column.rpe_px, column.top[static_cast<std::size_t>(RetinalLayer::rpe)]);
      EXPECT_LT(column.rpe_px, column.top[static_cast<std::size_t>(RetinalLayer::choroid)]);
    }
  }
}

TEST_F(RetinaModelTest, ParafovealRetinaIsAbout320UmThickAndThePitHalvesIt) {
  const hal::BeamPosition fovea{static_cast<float>(config_.fovea_x),
                                static_cast<float>(config_.fovea_y)};
  const hal::BeamPosition parafovea{-0.5f, -0.04f};  // temporal, 1.7 mm from the fovea
  // ILM to the RPE's centre: the layer table's 309 um, the RPE's half band and a little NFL.
  EXPECT_NEAR(thickness_um(model_, parafovea), 321.0, 6.0);
  EXPECT_LT(thickness_um(model_, fovea), 0.65 * thickness_um(model_, parafovea));
  EXPECT_GT(thickness_um(model_, fovea), 0.4 * thickness_um(model_, parafovea));
  // The inner layers are gone at the pit's centre; the outer retina is not.
  const RetinaColumn pit = model_.column(fovea);
  EXPECT_LT(pit.presence[static_cast<std::size_t>(RetinalLayer::ipl)], 0.15f);
  EXPECT_EQ(pit.presence[static_cast<std::size_t>(RetinalLayer::onl)], 1.0f);
}

TEST_F(RetinaModelTest, TheFundusCurvesTowardsTheViewerAtTheEdges) {
  const float center = model_.column({0.0f, 0.0f}).rpe_px;
  const float edges =
      0.5f * (model_.column({-1.0f, 0.0f}).rpe_px + model_.column({1.0f, 0.0f}).rpe_px);
  EXPECT_NEAR(center - edges, config_.curvature_fraction * kDepthBins, 0.5);
  EXPECT_GT(center - edges, 10.0f);
}

TEST_F(RetinaModelTest, MacularHoleRemovesTheNeuralRetinaAndThickensItsRim) {
  RetinaConfig hole = config_;
  hole.macular_hole.enabled = true;
  const RetinaModel model(hole, source_.axial_pixel_um(), kDepthBins);
  const float fx = static_cast<float>(config_.fovea_x);
  const float fy = static_cast<float>(config_.fovea_y);
  const RetinaColumn centre = model.column({fx, fy});
  EXPECT_TRUE(std::isnan(centre.ilm_px));
  EXPECT_EQ(centre.presence[static_cast<std::size_t>(RetinalLayer::os)], 0.0f);
  EXPECT_EQ(centre.rpe_px, model_.column({fx, fy}).rpe_px) << "the RPE stays";
  // Just outside the hole's 0.2 mm radius the retina is thicker than without the hole.
  const hal::BeamPosition rim{fx + static_cast<float>(0.25 / config_.field_half_width_mm), fy};
  EXPECT_GT(thickness_um(model, rim), thickness_um(model_, rim) + 40.0);
  EXPECT_GT(model.column(rim).cuff, 0.5f);
}

TEST_F(RetinaModelTest, OpticDiscThinsTheRetinaToACupWithoutRpe) {
  RetinaConfig with_disc = config_;
  with_disc.disc.enabled = true;
  const OpticDiscConfig& disc = with_disc.disc;
  const RetinaModel model(with_disc, source_.axial_pixel_um(), kDepthBins);
  const auto at_mm = [&](double r_mm) {  // nasally from the disc's centre
    return hal::BeamPosition{
        static_cast<float>(disc.center_x + r_mm / with_disc.field_half_width_mm),
        static_cast<float>(disc.center_y)};
  };
  const auto onl = static_cast<std::size_t>(RetinalLayer::onl);
  const float cup_px = static_cast<float>(disc.cup_depth_um / model.tissue_um_per_px());

  // Inside: nerve head, no RPE (nor its truth), the surface the cup's depth below where the
  // retina's would be, the layers still in order.
  const RetinaColumn centre = model.column(at_mm(0.0));
  EXPECT_TRUE(centre.in_disc);
  EXPECT_TRUE(std::isnan(centre.rpe_px));
  EXPECT_TRUE(std::isnan(model.layers(at_mm(0.0)).rpe_px));
  EXPECT_NEAR(centre.ilm_px - model_.column(at_mm(0.0)).ilm_px, cup_px, 0.01f);
  EXPECT_EQ(centre.presence[onl], 0.0f);
  for (std::size_t i = 1; i < centre.top.size(); ++i) EXPECT_LE(centre.top[i - 1], centre.top[i]);
  // The cup's wall: shallower half-way out, level with the retina from the cup's edge on.
  const float half_way = model.column(at_mm(0.5 * disc.cup_radius_mm)).ilm_px -
                         model_.column(at_mm(0.5 * disc.cup_radius_mm)).ilm_px;
  EXPECT_NEAR(half_way, 0.5f * cup_px, 0.01f * cup_px);
  const RetinaColumn rim = model.column(at_mm(0.5 * (disc.cup_radius_mm + disc.radius_mm)));
  EXPECT_TRUE(rim.in_disc);
  EXPECT_NEAR(rim.ilm_px, model_.column(at_mm(0.5 * (disc.cup_radius_mm + disc.radius_mm))).ilm_px,
              0.01f);

  // Over the margin the layers beneath the NFL thin out while the surface stays where it was;
  // beyond it the retina is the one without a disc.
  const hal::BeamPosition margin = at_mm(disc.radius_mm + 0.5 * disc.margin_mm);
  const RetinaColumn thinning = model.column(margin);
  EXPECT_FALSE(thinning.in_disc);
  EXPECT_NEAR(thinning.ilm_px, model_.column(margin).ilm_px, 0.01f);
  EXPECT_EQ(thinning.rpe_px, model_.column(margin).rpe_px);
  const auto thickness = [&](const RetinaColumn& c) { return c.top[onl + 1] - c.top[onl]; };
  EXPECT_LT(thickness(thinning), 0.75f * thickness(model_.column(margin)));
  const hal::BeamPosition beyond = at_mm(disc.radius_mm + disc.margin_mm + 0.05);
  EXPECT_EQ(model.column(beyond).ilm_px, model_.column(beyond).ilm_px);
  EXPECT_EQ(model.column(beyond).top, model_.column(beyond).top);
}

TEST_F(RetinaModelTest, MembraneLiesAboveTheIlmWhereItIs) {
  RetinaConfig erm = config_;
  erm.membrane.enabled = true;
  const RetinaModel model(erm, source_.axial_pixel_um(), kDepthBins);
  int above = 0;
  int lifted = 0;
  for (float x = -0.6f; x <= -0.1f; x += 0.01f) {
    const RetinaColumn c = model.column({x, 0.2f});
    if (!std::isfinite(c.membrane_top_px)) continue;
    ++above;
    EXPECT_LE(c.membrane_bottom_px, c.ilm_px + 1e-3f);
    EXPECT_LT(c.membrane_top_px, c.membrane_bottom_px);
    if (c.ilm_px - c.membrane_bottom_px > 2.0f) ++lifted;
  }
  EXPECT_GT(above, 40);
  EXPECT_GT(lifted, 5) << "partly lifted";
  EXPECT_LT(lifted, above) << "partly adherent";
  EXPECT_FALSE(std::isfinite(model.column({0.9f, -0.9f}).membrane_top_px)) << "far from it: none";
}

TEST(AnteriorSegmentModel, CorneaIrisAndLensLieWhereTheAnatomySays) {
  const SweptSourceConfig source;
  AnteriorSegmentConfig config;
  config.chamber_depth_mm = 2.4;
  const std::uint32_t depth_bins = 1376;  // 7.7 mm: the whole chamber
  const AnteriorSegmentModel model(config, source.axial_pixel_um(), depth_bins);
  const double px_per_mm = 1e3 / source.axial_pixel_um();
  const AnteriorColumn apex = model.column({0.0f, 0.0f});
  EXPECT_NEAR(apex.epithelium_px, config.apex_depth_fraction * depth_bins, 1e-3);
  // 540 um of cornea at group index 1.376.
  EXPECT_NEAR(apex.endothelium_px - apex.epithelium_px, 0.540 * 1.376 * px_per_mm, 0.5);
  // The lens lies the chamber depth below the apex, through aqueous.
  EXPECT_NEAR(apex.lens_px - apex.epithelium_px,
              (0.540 * 1.376 + (2.4 - 0.540) * 1.336) * px_per_mm, 0.5);
  EXPECT_TRUE(std::isnan(apex.iris_front_px)) << "the pupil";
  // 3 mm out: iris in front of the lens, the cornea curved down.
  const AnteriorColumn side =
      model.column({static_cast<float>(3.0 / config.field_half_width_mm), 0.0f});
  EXPECT_TRUE(std::isfinite(side.iris_front_px));
  EXPECT_GT(side.epithelium_px, apex.epithelium_px + 0.5 * px_per_mm);
  EXPECT_LT(side.iris_front_px, side.lens_px);
  EXPECT_GT(side.iris_front_px, side.endothelium_px);
}

TEST(InstrumentModel, TheBeamMeetsTheShaftOnTopAndTheTipEnds) {
  const SweptSourceConfig source;
  InstrumentConfig needle;
  needle.kind = InstrumentKind::needle;
  needle.pose = {0.0f, 0.0f, 0.3f, 0.0f, 0.0f, 0.0f};  // level, shaft towards +x
  InstrumentModel model(needle, 3.0, source.axial_pixel_um(), 688);
  const double px_per_mm = 1e3 * 1.336 / source.axial_pixel_um();
  const ToolHit over = model.hit({0.2f, 0.0f});
  ASSERT_TRUE(over.hit);
  // The top of a 0.155 mm radius needle whose axis lies at 30% of the axis.
  EXPECT_NEAR(over.entry_px, 0.3 * 688 - 0.155 * px_per_mm, 0.05);
  EXPECT_EQ(over.transmission, 0.0f);
  EXPECT_GT(over.amplitude, 3.0f) << "facing the beam: bright";
  EXPECT_FALSE(model.hit({-0.2f, 0.0f}).hit) << "beyond the tip";
  EXPECT_FALSE(model.hit({0.2f, 0.1f}).hit) << "beside the shaft";
  const ToolHit flank = model.hit({0.2f, static_cast<float>(0.14 / 3.0)});
  ASSERT_TRUE(flank.hit);
  EXPECT_LT(flank.amplitude, 0.5f * over.amplitude) << "the flank faces away";

  // Moving: the pose follows the velocity.
  needle.motion.velocity_x = 0.5f;
  const InstrumentModel moving(needle, 3.0, source.axial_pixel_um(), 688);
  EXPECT_FLOAT_EQ(moving.pose_at(0.2).tip_x, 0.1f);
  EXPECT_FLOAT_EQ(moving.state(moving.pose_at(0.0)).tip_depth_px, 0.3f * 688);
}

TEST(InstrumentModel, ScraperPaddleIsTranslucent) {
  const SweptSourceConfig source;
  InstrumentConfig scraper;
  scraper.kind = InstrumentKind::scraper;
  scraper.pose = {0.0f, 0.0f, 0.3f, 0.0f, 0.0f, 0.0f};
  InstrumentModel model(scraper, 3.0, source.axial_pixel_um(), 688);
  const ToolHit paddle = model.hit({static_cast<float>(0.5 / 3.0), 0.0f});  // mid-paddle
  ASSERT_TRUE(paddle.hit);
  EXPECT_GT(paddle.transmission, 0.0f);
  EXPECT_GT(paddle.exit_px, paddle.entry_px);
  const ToolHit shaft = model.hit({static_cast<float>(2.0 / 3.0), 0.0f});
  ASSERT_TRUE(shaft.hit);
  EXPECT_EQ(shaft.transmission, 0.0f);
}

}  // namespace
}  // namespace ioct::sim
