// Dispersion compensation: a dispersed reflector is blurred; the right c2, c3 make it as sharp
// as an undispersed one, and the estimator finds them from the data alone.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "ioct/gpu/processing/dispersion_estimator.hpp"
#include "ioct/gpu/processing/volume_sharpness.hpp"
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

// ---- The case that failed on a real spectrometer set, simulated ----------------------------
//
// 2048 samples linear in wavelength (resampled to k with a cubic calibration), 400 A-scans, a
// retina-like band of weak speckle (a few counts against a noise of 4 counts) over a brighter
// RPE, strong fixed-pattern lines from the optics and a source power (and lines) that fluctuate
// by 3% from sweep to sweep, so a residue of the DC and of the lines is left in every A-scan.
// The dispersion (c2, c3) is put into the fringes with the convention of dispersion.hpp, so a
// recovered estimate within the stated tolerance, which sharpens the chain's volume, checks the
// estimator's sign and scale against the chain's end to end. On these groups the estimator
// before the metric measured tissue returned c3 = -45 rad for the small cases and c2 = +-88,
// c3 = 85 rad for the large ones.

constexpr std::uint32_t kSpectrometerSamples = 2048;
const std::vector<double> kCalibration{0.0, 0.9, 0.14, -0.04};  // x(t) / (N - 1), cubic
const std::vector<Reflector> kFixedLines{
    {90.0, 150.0}, {262.0, 120.0}, {560.0, 100.0}, {700.0, 150.0}};

OctProcessorConfig spectrometer_config() {
  OctProcessorConfig config = testing::quick_config();
  config.resampling.interpolation = Interpolation::cubic;
  config.resampling.coefficients = kCalibration;
  config.scale = {.db_min = -5.0, .db_max = 30.0};  // a weak signal's range
  return config;
}

Group spectrometer_group(double c2, double c3, bool tissue = true, std::uint32_t seed = 3) {
  Group g;
  g.geometry.samples_per_ascan = kSpectrometerSamples;
  g.geometry.ascans_per_bscan = 200;
  g.geometry.bscans_per_group = 2;
  g.geometry.bscans_per_volume = 2;
  testing::SpectrumModel model{.samples = kSpectrometerSamples, .noise_sigma = 4.0};
  model.c2 = c2;
  model.c3 = c3;
  model.k_of_sample = testing::k_of_raw_samples(kCalibration, kSpectrometerSamples);
  model.fixed_pattern_lines = kFixedLines;
  model.power_jitter = 0.03;
  model.fixed_pattern_jitter = 0.03;
  testing::SpectrumSynthesizer synthesizer(model, seed);
  std::mt19937 rng(seed + 100);
  g.payload.resize(g.geometry.group_payload_bytes() / 2);
  testing::fill_group(
      g.geometry, synthesizer,
      [&](std::uint32_t b, std::uint32_t a) {
        std::vector<Reflector> r;
        if (!tissue) return r;
        const double surface = 330.0 + 25.0 * std::sin((a + 200.0 * b) / 70.0);
        std::uniform_real_distribution<double> where(0.0, 150.0);
        std::exponential_distribution<double> speckle(1.0 / 1.5);
        for (int i = 0; i < 40; ++i) r.push_back({surface + where(rng), speckle(rng)});
        r.push_back({surface + 160.0, 6.0 + speckle(rng)});  // the RPE
        return r;
      },
      g.payload);
  g.header = testing::header_for(g.geometry, 0, g.geometry.ascans_per_bscan);
  return g;
}

DispersionSearch spectrometer_search() {
  DispersionSearch search;
  search.c2_limit = 100.0;
  search.c3_limit = 50.0;
  search.ascans = 128;
  return search;
}

// The standard sharpness of the group processed by the chain at (c2, c3), over the rows below
// the DC region away from the known fixed-pattern lines, widened by the chirp of `spread`.
double chain_sharpness(const Group& g, double c2, double c3, const DispersionConfig& spread) {
  OctProcessorConfig config = spectrometer_config();
  config.background.groups = 1;
  config.dispersion = {c2, c3};
  CpuOctProcessor processor(config);
  processor.prepare(g.geometry);
  ProcessedGroup out;
  processor.process(RawGroup{g.header, g.payload}, out);
  const std::uint32_t reach =
      chirp_spread_rows(spread, make_window(config.window.kind, kSpectrometerSamples));
  std::vector<std::uint8_t> kept(out.depth, 1);
  for (std::uint32_t d = 0; d < out.depth; ++d) {
    if (d < 32 + reach) kept[d] = 0;
    for (const Reflector& line : kFixedLines) {
      if (std::abs(d - line.depth_bin) <= 3.0 + reach) kept[d] = 0;
    }
  }
  return volume_sharpness(out, config.scale, kept);
}

struct SpectrometerCase {
  double c2 = 0.0;
  double c3 = 0.0;
  double tolerance = 0.0;  // radians, on c2 and c3
};

class DispersionOnSpectrometerData : public ::testing::TestWithParam<SpectrometerCase> {};

TEST_P(DispersionOnSpectrometerData, TheEstimateIsNearTheTruthAndNeverBlursTheVolume) {
  const SpectrometerCase c = GetParam();
  const Group g = spectrometer_group(c.c2, c.c3);
  DispersionEstimator estimator(spectrometer_config(), spectrometer_search());
  estimator.load(g.geometry, RawGroup{g.header, g.payload});
  const DispersionEstimate e = estimator.estimate();
  SCOPED_TRACE(describe_check(e));
  // The artifacts were recognised as such: the DC region, and every fixed-pattern line.
  EXPECT_EQ(e.dc_rows, 32u);
  for (const Reflector& line : kFixedLines) {
    EXPECT_TRUE(std::ranges::any_of(
        e.fixed_pattern_rows,
        [&](std::uint32_t row) { return std::abs(row - line.depth_bin) <= 1.0; }))
        << "the line at row " << line.depth_bin << " was not found";
  }
  for (const std::uint32_t row : e.fixed_pattern_rows) {  // and nothing else (no tissue)
    EXPECT_TRUE(std::ranges::any_of(
        kFixedLines, [&](const Reflector& line) { return std::abs(row - line.depth_bin) <= 3.0; }))
        << "row " << row << " taken for a fixed-pattern line";
  }
  EXPECT_FALSE(e.depth_dependent) << e.c2_shallow << " above row " << e.depth_split << ", "
                                  << e.c2_deep << " below";
  EXPECT_NEAR(e.c2, c.c2, c.tolerance) << "searched c2 " << e.searched_c2;
  EXPECT_NEAR(e.c3, c.c3, c.tolerance) << "searched c3 " << e.searched_c3;
  // Judged independently of the estimator's own figures, on the chain's volume.
  const DispersionConfig spread{std::max(std::abs(e.c2), std::abs(c.c2)),
                                std::max(std::abs(e.c3), std::abs(c.c3))};
  const double at_estimate = chain_sharpness(g, e.c2, e.c3, spread);
  const double uncompensated = chain_sharpness(g, 0.0, 0.0, spread);
  EXPECT_GE(at_estimate, uncompensated);
  if (std::abs(c.c2) >= 20.0) {
    EXPECT_GT(at_estimate, 1.2 * uncompensated);  // it helps
  }
}

INSTANTIATE_TEST_SUITE_P(FewNoisyAscansWithFixedPatternAndDc, DispersionOnSpectrometerData,
                         ::testing::Values(SpectrometerCase{0.0, 0.0, 1.5},
                                           SpectrometerCase{3.0, -1.0, 1.5},
                                           SpectrometerCase{-4.0, 2.0, 1.5},
                                           SpectrometerCase{40.0, -15.0, 2.0},
                                           SpectrometerCase{-60.0, 20.0, 2.0}),
                         [](const ::testing::TestParamInfo<SpectrometerCase>& param) {
                           return "case" + std::to_string(param.index);
                         });

TEST(Dispersion, AnEstimateThatBlursTheProcessedVolumeIsRejected) {
  // The values the old estimator reported for a set whose optimum is near 0.
  const Group g = spectrometer_group(0.0, 0.0);
  DispersionEstimator estimator(spectrometer_config(), spectrometer_search());
  estimator.load(g.geometry, RawGroup{g.header, g.payload});
  DispersionEstimate e;
  e.searched_c2 = -49.2;
  e.searched_c3 = 33.9;
  estimator.check(e);
  EXPECT_TRUE(e.checked);
  EXPECT_TRUE(e.rejected);
  EXPECT_EQ(e.c2, 0.0);
  EXPECT_EQ(e.c3, 0.0);
  EXPECT_LT(e.processed_sharpness, e.processed_sharpness_uncompensated);
  EXPECT_NE(describe_check(e).find("rejected"), std::string::npos) << describe_check(e);
  // The truth passes the same check.
  const Group dispersed = spectrometer_group(40.0, -15.0);
  estimator.load(dispersed.geometry, RawGroup{dispersed.header, dispersed.payload});
  DispersionEstimate right;
  right.searched_c2 = 40.0;
  right.searched_c3 = -15.0;
  estimator.check(right);
  EXPECT_FALSE(right.rejected);
  EXPECT_EQ(right.c2, 40.0);
  EXPECT_GT(right.processed_sharpness, right.processed_sharpness_uncompensated);
}

TEST(Dispersion, ArtifactsAloneGiveNoCorrection) {
  // No tissue: only noise, DC residue and fixed-pattern lines. Whatever the search finds in the
  // noise, the result must not blur the volume.
  const Group g = spectrometer_group(0.0, 0.0, /*tissue=*/false);
  DispersionEstimator estimator(spectrometer_config(), spectrometer_search());
  estimator.load(g.geometry, RawGroup{g.header, g.payload});
  const DispersionEstimate e = estimator.estimate();
  SCOPED_TRACE(describe_check(e));
  EXPECT_GE(e.processed_sharpness, e.processed_sharpness_uncompensated);
  const DispersionConfig spread{std::abs(e.searched_c2), std::abs(e.searched_c3)};
  EXPECT_GE(chain_sharpness(g, e.c2, e.c3, spread), chain_sharpness(g, 0.0, 0.0, spread));
}

}  // namespace
}  // namespace ioct::gpu
