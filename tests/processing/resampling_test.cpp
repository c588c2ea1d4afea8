// lambda -> k resampling: the calibration is validated, the interpolation is accurate (cubic
// more than linear), and a chirped (non-k-linear) sweep comes out as a sharp layer at its depth.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "ioct/gpu/processing/resampling.hpp"
#include "processing_fixture.hpp"

namespace ioct::gpu {
namespace {

using testing::Reflector;

ResamplingConfig calibration(Interpolation interpolation, std::vector<double> coefficients) {
  ResamplingConfig config;
  config.interpolation = interpolation;
  config.coefficients = std::move(coefficients);
  return config;
}

// Throws ConfigError for `key` whose message holds `fragment`.
void expect_calibration_error(const ResamplingConfig& config, std::uint32_t samples,
                              const std::string& key, const std::string& fragment) {
  try {
    config.validate_for(samples);
    FAIL() << "calibration accepted: " << format_coefficients(config.coefficients);
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Resampling, CalibrationIsValidatedNamingWhatIsWrong) {
  expect_calibration_error(calibration(Interpolation::linear, {0.0, std::nan("")}), 1024,
                           "resampling_coefficients[1]", "nan");
  expect_calibration_error(calibration(Interpolation::cubic, {0.0, INFINITY}), 1024,
                           "resampling_coefficients[1]", "finite");
  // Falls from x(0) = 0.5 (N - 1) to 0.33 (N - 1) before it rises: not monotonic.
  expect_calibration_error(calibration(Interpolation::linear, {0.5, -1.0, 1.5}), 1024,
                           "resampling_coefficients", "not monotonic");
  // Reads past the sweep's end.
  expect_calibration_error(calibration(Interpolation::linear, {0.0, 1.2}), 1024,
                           "resampling_coefficients", "leaves the sweep");
  expect_calibration_error(calibration(Interpolation::linear, {}), 1024, "resampling_coefficients",
                           "1 to 8");
  // Without resampling the calibration's shape is not checked (only that its numbers are).
  EXPECT_NO_THROW(calibration(Interpolation::none, {0.5, -1.0, 1.5}).validate_for(1024));
  EXPECT_NO_THROW(calibration(Interpolation::cubic, {0.0, 0.85, 0.15}).validate_for(1024));

  // The processor refuses such a calibration at prepare(), with the same error.
  OctProcessorConfig config = testing::quick_config();
  config.resampling = calibration(Interpolation::linear, {0.5, -1.0, 1.5});
  CpuOctProcessor processor(config);
  shm::RingGeometry g;
  g.samples_per_ascan = 256;
  g.ascans_per_bscan = 8;
  g.bscans_per_group = 2;
  EXPECT_THROW(processor.prepare(g), ConfigError);
}

TEST(Resampling, CoefficientsParseFromText) {
  EXPECT_EQ(parse_coefficients("0, 1,-0.02"), (std::vector<double>{0.0, 1.0, -0.02}));
  EXPECT_EQ(parse_coefficients("1e-3"), (std::vector<double>{1e-3}));
  for (const char* bad : {"", "0,,1", "0,1,x", "0;1"}) {
    EXPECT_THROW(parse_coefficients(bad), ConfigError) << "'" << bad << "'";
  }
}

// The table applied to samples of a smooth function reproduces the function at x(j).
double max_interpolation_error(Interpolation interpolation, double cycles_per_sample) {
  constexpr std::uint32_t kSamples = 1024;
  const ResamplingConfig config = calibration(interpolation, {0.0, 0.85, 0.15});
  const ResamplingTable table = make_resampling_table(config, kSamples);
  const auto f = [&](double x) { return std::cos(2.0 * std::numbers::pi * cycles_per_sample * x); };
  std::vector<float> raw(kSamples);
  for (std::uint32_t s = 0; s < kSamples; ++s) raw[s] = static_cast<float>(f(s));
  double worst = 0.0;
  for (std::uint32_t j = 0; j < kSamples; ++j) {
    double value = 0.0;
    for (std::uint32_t t = 0; t < table.taps; ++t) {
      value += table.weights[j * table.taps + t] * raw[table.first[j] + t];
    }
    const double expected = f(calibration_position(config.coefficients, kSamples, j));
    // The ends are extrapolated by repeating the end sample: judge the interior.
    if (j > 2 && j + 3 < kSamples) worst = std::max(worst, std::abs(value - expected));
  }
  return worst;
}

TEST(Resampling, InterpolatesASmoothSignalAndCubicBeatsLinear) {
  // A fringe of 0.05 cycles per sample (20 samples a cycle): linear interpolation errs by about
  // (pi f)^2 / 2 = 1.2%, cubic convolution by far less.
  const double linear = max_interpolation_error(Interpolation::linear, 0.05);
  const double cubic = max_interpolation_error(Interpolation::cubic, 0.05);
  EXPECT_LT(linear, 0.02);
  EXPECT_GT(linear, 0.002);  // the test can tell the two apart
  EXPECT_LT(cubic, 0.2 * linear);
  // Every row of weights sums to 1: a constant stays constant.
  const ResamplingTable table =
      make_resampling_table(calibration(Interpolation::cubic, {0.0, 0.85, 0.15}), 512);
  for (std::uint32_t j = 0; j < 512; ++j) {
    double sum = 0.0;
    for (std::uint32_t t = 0; t < table.taps; ++t) sum += table.weights[j * table.taps + t];
    EXPECT_NEAR(sum, 1.0, 1e-6) << "j = " << j;
  }
}

// A swept source without k-clock: raw sample s is taken at wavenumber k(s), the inverse of the
// calibration x(k) = (N - 1) (0.85 u + 0.15 u^2), u = k / (N - 1). A reflector is a pure tone in
// k, so in raw samples its frequency sweeps from 1.18x to 0.74x of nominal.
std::vector<double> chirped_sampling(std::uint32_t samples) {
  std::vector<double> k(samples);
  for (std::uint32_t s = 0; s < samples; ++s) {
    const double target = static_cast<double>(s) / (samples - 1);
    const double u = (-0.85 + std::sqrt(0.85 * 0.85 + 4.0 * 0.15 * target)) / (2.0 * 0.15);
    k[s] = u * (samples - 1);
  }
  return k;
}

struct ChirpResult {
  double peak_error = 0.0;  // mean |brightest depth - true depth|
  double mean_peak = 0.0;   // mean u8 at the brightest depth
  double mean_width = 0.0;  // mean width 6 levels (about 1 dB) below the peak
};

ChirpResult process_chirp(Interpolation interpolation, bool chirped) {
  shm::RingGeometry g;
  g.samples_per_ascan = 1024;
  g.ascans_per_bscan = 32;
  g.bscans_per_group = 2;
  g.bscans_per_volume = 2;
  testing::SpectrumModel model{.samples = g.samples_per_ascan, .noise_sigma = 1.0};
  if (chirped) model.k_of_sample = chirped_sampling(g.samples_per_ascan);
  testing::SpectrumSynthesizer synthesizer(model, 5);
  std::vector<std::uint16_t> payload(g.group_payload_bytes() / 2);
  constexpr double kDepth = 180.0;
  testing::fill_group(
      g, synthesizer,
      [](std::uint32_t, std::uint32_t) {
        return std::vector<Reflector>{{kDepth, 40.0}};
      },
      payload);
  OctProcessorConfig config = testing::quick_config();
  config.resampling = calibration(interpolation, {0.0, 0.85, 0.15});
  CpuOctProcessor processor(config);
  processor.prepare(g);
  ProcessedGroup out;
  processor.process(RawGroup{testing::header_for(g, 0, g.ascans_per_bscan), payload}, out);
  ChirpResult r;
  const double n = static_cast<double>(out.bscan_count * out.ascans);
  for (std::uint32_t b = 0; b < out.bscan_count; ++b) {
    for (std::uint32_t a = 0; a < out.ascans; ++a) {
      const auto ascan = testing::ascan_of(out, b, a);
      const std::uint32_t peak = testing::brightest_depth(ascan);
      r.peak_error += std::abs(static_cast<double>(peak) - kDepth) / n;
      r.mean_peak += ascan[peak] / n;
      r.mean_width += testing::peak_width(ascan, 6) / n;
    }
  }
  return r;
}

TEST(Resampling, AChirpedSweepBecomesASharpLayerAtItsDepth) {
  const ChirpResult reference = process_chirp(Interpolation::none, false);  // k-clocked
  const ChirpResult smeared = process_chirp(Interpolation::none, true);
  const ChirpResult linear = process_chirp(Interpolation::linear, true);
  const ChirpResult cubic = process_chirp(Interpolation::cubic, true);
  // Without resampling the layer smears over tens of pixels and loses most of its brightness.
  EXPECT_GT(smeared.mean_width, 4.0 * reference.mean_width);
  EXPECT_LT(smeared.mean_peak, reference.mean_peak - 40.0);
  for (const ChirpResult* r : {&linear, &cubic}) {
    EXPECT_LT(r->peak_error, 0.75);
    EXPECT_LT(r->mean_width, 1.5 * reference.mean_width + 1.0);
    EXPECT_GT(r->mean_peak, reference.mean_peak - 6.0);
  }
  // Linear interpolation attenuates a fringe of ~0.2 cycles per sample; cubic much less.
  EXPECT_GE(cubic.mean_peak, linear.mean_peak);
}

}  // namespace
}  // namespace ioct::gpu
