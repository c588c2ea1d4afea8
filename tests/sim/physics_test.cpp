// The simulator's physics, measured the way a bench engineer would: sensitivity roll-off along a
// tilted mirror, axial broadening by dispersion mismatch (and its compensation by the documented
// phase), speckle that keeps flat layers out of the mean spectrum, lambda-linear sampling that
// the calibration polynomial resamples, shadows under instruments, and the anterior segment and
// pathologies where their models put them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include "ioct/sim/anterior_segment_model.hpp"
#include "ioct/sim/mirror_model.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "spectrum_fft.hpp"

namespace ioct::sim {
namespace {

using Magnitude = std::vector<float>;

struct Acquired {
  std::vector<std::uint16_t> group;
  GroupTruth truth;
  std::vector<double> background;  // group mean spectrum
};

Acquired acquire_one(const SimulationConfig& simulation, const hal::DigitizerConfig& geometry) {
  SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(geometry);
  digitizer.start();
  Acquired a;
  a.group.resize(geometry.samples_per_group());
  hal::GroupInfo info;
  digitizer.acquire_group(a.group, info);
  a.truth = digitizer.last_group_truth();
  a.background = test::mean_spectrum(a.group, geometry.samples_per_ascan);
  return a;
}

std::span<const std::uint16_t> record(const Acquired& a, std::size_t r, std::uint32_t n) {
  return std::span<const std::uint16_t>(a.group).subspan(r * n, n);
}

hal::DigitizerConfig line_geometry(std::uint32_t samples, std::uint32_t ascans,
                                   std::uint32_t bscans = 1) {
  hal::DigitizerConfig geometry;
  geometry.samples_per_ascan = samples;
  geometry.ascans_per_bscan = ascans;
  geometry.flyback_sweeps = 2;
  geometry.bscans_per_group = bscans;
  return geometry;
}

SimulationConfig mirror_simulation(std::uint32_t ascans, double depth, double tilt) {
  SimulationConfig s;
  s.preset = SamplePreset::mirror;
  s.mirror.depth_fraction = depth;
  s.mirror.tilt_x_fraction = tilt;
  s.scan.ascans_per_bscan = ascans;
  s.scan.bscans_per_volume = 1;
  s.scan.extent_y = 0.0f;
  return s;
}

// FWHM (bins) of the peak near `depth` of a complex spectrum, read on an 8x zero-padded FFT so
// that narrow and broad peaks are measured alike.
double fine_fwhm(std::span<const std::complex<double>> x, double depth) {
  constexpr std::uint32_t kPad = 8;
  const auto n = static_cast<std::uint32_t>(x.size());
  std::vector<std::complex<double>> padded(std::size_t{n} * kPad);
  std::copy(x.begin(), x.end(), padded.begin());
  test::SpectrumFft fft(n * kPad);
  const auto magnitude = fft.magnitude_of(std::span<const std::complex<double>>(padded));
  const std::uint32_t peak =
      test::peak_near(magnitude, static_cast<float>(depth * kPad), 30 * kPad);
  return test::peak_fwhm(magnitude, peak) / kPad;
}

TEST(Physics, SensitivityRollsOffBySixDecibelsAtTheConfiguredDepth) {
  const std::uint32_t n = 1376;
  const hal::DigitizerConfig geometry = line_geometry(n, 160);
  for (const double configured_mm : {3.9, 2.0}) {
    SCOPED_TRACE(configured_mm);
    // A mirror tilted from 8% to 92% of the depth axis across the line.
    SimulationConfig s = mirror_simulation(160, 0.5, 0.42);
    s.source.rolloff_6db_depth_mm = configured_mm;
    const Acquired a = acquire_one(s, geometry);
    const MirrorModel mirror(s.mirror, s.source.axial_pixel_um(), s.source.k_min(), n / 2);
    test::SpectrumFft fft(n);
    // log2(amplitude) = log2(A0) - (z / z6)^2: a straight line in z^2.
    double sx = 0, sy = 0, sxx = 0, sxy = 0, count = 0;
    for (std::size_t r = 0; r < 160; ++r) {
      const float depth = mirror.depth_px({a.truth.beam_x[r], a.truth.beam_y[r]});
      const auto magnitude = fft.magnitude(record(a, r, n), a.background);
      const std::uint32_t peak = test::peak_near(magnitude, depth, 3);
      ASSERT_NEAR(static_cast<float>(peak), depth, 1.0f) << r;
      const double z_mm = depth * s.source.axial_pixel_um() * 1e-3;
      const double y = std::log2(test::peak_energy(magnitude, peak, 4));
      sx += z_mm * z_mm;
      sy += y;
      sxx += z_mm * z_mm * z_mm * z_mm;
      sxy += z_mm * z_mm * y;
      count += 1;
    }
    const double slope = (count * sxy - sx * sy) / (count * sxx - sx * sx);
    const double measured_mm = 1.0 / std::sqrt(-slope);
    std::printf("[ roll-off ] configured -6 dB at %.2f mm, measured %.3f mm\n", configured_mm,
                measured_mm);
    EXPECT_NEAR(measured_mm, configured_mm, 0.04 * configured_mm);
  }
}

// The PSF a dispersion mismatch gives, computed from the documented model directly (source
// envelope times exp(i (c2 t^2 + c3 t^3)) over the k-linear sweep), in double precision.
double model_fwhm(const SweptSourceConfig& source, double c2, double c3, std::uint32_t n,
                  double depth) {
  std::vector<std::complex<double>> x(n);
  const double k_step = (source.k_max() - source.k_min()) / n;
  for (std::uint32_t j = 0; j < n; ++j) {
    const double t = 2.0 * j / (n - 1.0) - 1.0;
    const double phase = c2 * t * t + c3 * t * t * t + 2.0 * std::numbers::pi * j * depth / n;
    x[j] = source.power_at_k(source.k_min() + j * k_step) * std::polar(1.0, phase);
  }
  return fine_fwhm(x, depth);
}

TEST(Physics, DispersionMismatchBroadensAsConfiguredAndTheDocumentedPhaseUndoesIt) {
  const std::uint32_t n = 1376;
  const std::uint32_t ascans = 96;
  const hal::DigitizerConfig geometry = line_geometry(n, ascans);
  const auto measure = [&](double c2, double c3, bool compensate) {
    SimulationConfig s = mirror_simulation(ascans, 0.45, 0.1);
    s.interferometer.dispersion_c2 = c2;
    s.interferometer.dispersion_c3 = c3;
    const Acquired a = acquire_one(s, geometry);
    const MirrorModel mirror(s.mirror, s.source.axial_pixel_um(), s.source.k_min(), n / 2);
    double width = 0.0;
    for (std::size_t r = 0; r < ascans; ++r) {
      const std::span<const std::uint16_t> spectrum = record(a, r, n);
      std::vector<std::complex<double>> x(n);
      for (std::uint32_t j = 0; j < n; ++j) {
        const double t = 2.0 * j / (n - 1.0) - 1.0;
        const double phase = compensate ? -(c2 * t * t + c3 * t * t * t) : 0.0;
        x[j] = (spectrum[j] - a.background[j]) * std::polar(1.0, phase);
      }
      const float depth = mirror.depth_px({a.truth.beam_x[r], a.truth.beam_y[r]});
      width += fine_fwhm(x, depth);
    }
    return width / ascans;
  };
  const SweptSourceConfig source;
  const double plain = measure(0.0, 0.0, false);
  const double chirped = measure(6.0, 0.0, false);
  const double expected_ratio =
      model_fwhm(source, 6.0, 0.0, n, 300.0) / model_fwhm(source, 0.0, 0.0, n, 300.0);
  std::printf("[ disp     ] FWHM %.2f bins plain, %.2f with c2 = 6 rad (x%.2f, model x%.2f)\n",
              plain, chirped, chirped / plain, expected_ratio);
  EXPECT_GT(expected_ratio, 3.0);
  EXPECT_NEAR(chirped / plain, expected_ratio, 0.1 * expected_ratio);
  EXPECT_NEAR(measure(6.0, 0.0, true), plain, 0.08 * plain) << "compensated with exp(-i phi)";
  // A cubic term broadens too, and the same convention undoes it.
  const double cubic = measure(0.0, 8.0, false);
  EXPECT_GT(cubic, 1.5 * plain);
  EXPECT_NEAR(measure(2.0, 8.0, true), plain, 0.08 * plain);
}

TEST(Physics, SpeckleKeepsAFlatLayerOutOfTheMeanSpectrum) {
  // A flat retina: every A-scan of the group sees its layers at the same depths. With a phase
  // that depended only on depth, the layers would be the same fringe in every spectrum: the
  // group's mean spectrum would hold them, and subtracting it would wipe them out and leave
  // coherent lines; with a random phase per scatterer the mean holds only a 1/sqrt(M) residue.
  const std::uint32_t n = 1376;
  const hal::DigitizerConfig geometry = line_geometry(n, 256, 4);
  SimulationConfig s;
  s.retina.curvature_fraction = 0.0;
  s.retina.tilt_x_fraction = 0.0;
  s.retina.tilt_y_fraction = 0.0;
  s.retina.foveal_pit_depth = 0.0;
  s.retina.nfl_growth_nasal_um_per_mm = 0.0;
  s.retina.nfl_growth_temporal_um_per_mm = 0.0;
  s.scan.ascans_per_bscan = 256;
  s.scan.bscans_per_volume = 4;
  const Acquired a = acquire_one(s, geometry);
  const float rpe = a.truth.rpe_px[0];
  const float ilm = a.truth.ilm_px[0];
  EXPECT_EQ(a.truth.rpe_px[300], rpe);
  test::SpectrumFft fft(n);
  double own_mean = 0.0;
  double group_mean = 0.0;
  const std::size_t records = 256 * 4;
  for (std::size_t r = 0; r < records; ++r) {
    const auto own = fft.magnitude(record(a, r, n));
    own_mean += own[test::peak_near(own, rpe, 1)];
    const auto subtracted = fft.magnitude(record(a, r, n), a.background);
    group_mean += subtracted[test::peak_near(subtracted, rpe, 1)];
  }
  own_mean /= records;
  group_mean /= records;
  EXPECT_GT(group_mean, 0.95 * own_mean) << "subtracting the group mean keeps the layer";
  // The mean spectrum itself, around the retina's depths, is nearly empty.
  std::vector<double> centred(a.background);
  double dc = 0.0;
  for (double v : centred) dc += v;
  for (double& v : centred) v -= dc / n;
  const auto mean_magnitude = fft.magnitude_of(std::span<const double>(centred));
  float coherent = 0.0f;
  for (auto bin = static_cast<std::uint32_t>(ilm) - 2; bin <= static_cast<std::uint32_t>(rpe) + 2;
       ++bin) {
    coherent = std::max(coherent, mean_magnitude[bin]);
  }
  std::printf("[ speckle  ] RPE %.0f per A-scan, strongest coherent residue %.1f in the mean\n",
              own_mean, coherent);
  EXPECT_LT(coherent, 0.1 * own_mean);
}

// Cubic convolution (Keys, a = -0.5) of `raw` at position x.
double cubic_at(std::span<const double> raw, double x) {
  const auto i = static_cast<std::int64_t>(std::floor(x));
  const double f = x - static_cast<double>(i);
  const auto at = [&](std::int64_t k) {
    return raw[static_cast<std::size_t>(std::clamp<std::int64_t>(k, 0, raw.size() - 1))];
  };
  const double p0 = at(i - 1), p1 = at(i), p2 = at(i + 1), p3 = at(i + 2);
  return p1 + 0.5 * f *
                  (p2 - p0 +
                   f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)));
}

TEST(Physics, LambdaLinearSamplingIsResampledByTheCalibrationPolynomial) {
  const std::uint32_t n = 1376;
  const std::uint32_t ascans = 64;
  hal::DigitizerConfig geometry = line_geometry(n, ascans);
  geometry.clock_source = hal::ClockSource::internal;
  SimulationConfig s = mirror_simulation(ascans, 0.45, 0.3);  // 15% to 75% of the axis
  SimulatedDigitizer digitizer(s);
  digitizer.prepare(geometry);
  digitizer.start();
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  digitizer.acquire_group(group, info);
  const KCalibration& calibration = digitizer.sampling().calibration;
  ASSERT_GT(calibration.coefficients.size(), 2u);
  const std::vector<double> background = test::mean_spectrum(group, n);
  const MirrorModel mirror(s.mirror, s.source.axial_pixel_um(), s.source.k_min(), n / 2);
  const GroupTruth& truth = digitizer.last_group_truth();
  test::SpectrumFft fft(n);
  double raw_width = 0.0;
  double resampled_width = 0.0;
  int deep = 0;
  for (std::uint32_t r = 0; r < ascans; ++r) {
    std::vector<double> raw(n);
    for (std::uint32_t i = 0; i < n; ++i) raw[i] = group[r * n + i] - background[i];
    std::vector<double> resampled(n);
    for (std::uint32_t j = 0; j < n; ++j)
      resampled[j] = cubic_at(raw, calibration.raw_position(n, j));
    const float depth = mirror.depth_px({truth.beam_x[r], truth.beam_y[r]});
    const auto resampled_magnitude = fft.magnitude_of(std::span<const double>(resampled));
    const Magnitude k_linear(resampled_magnitude.begin(), resampled_magnitude.end());
    const std::uint32_t peak = test::peak_near(k_linear, depth, 3);
    EXPECT_NEAR(test::interpolated_peak(k_linear, peak), depth, 0.5) << r;
    if (depth > 0.5f * n / 2) {
      ++deep;
      resampled_width += test::peak_fwhm(k_linear, peak);
      const auto unresampled = fft.magnitude_of(std::span<const double>(raw));
      raw_width += test::peak_fwhm(unresampled, test::peak_near(unresampled, depth, 40));
    }
  }
  ASSERT_GT(deep, 10);
  std::printf("[ lambda   ] deep peaks: FWHM %.1f bins raw, %.2f after resampling\n",
              raw_width / deep, resampled_width / deep);
  EXPECT_LT(resampled_width / deep, 2.0) << "sharp again after resampling";
  EXPECT_GT(raw_width / deep, 3.0 * resampled_width / deep) << "smeared without it";
}

TEST(Physics, MetalInstrumentsReflectStronglyAndShadowTheRetina) {
  const std::uint32_t n = 1376;
  const std::uint32_t ascans = 128;
  const hal::DigitizerConfig geometry = line_geometry(n, ascans);
  SimulationConfig s;
  s.scan.ascans_per_bscan = ascans;
  s.scan.bscans_per_volume = 1;
  s.scan.extent_y = 0.0f;
  // Forceps lying along the line, their tip in the middle, shaft to the left.
  s.instruments.push_back({InstrumentKind::forceps, {0.0f, 0.0f, 0.42f, 180.0f, 15.0f, 20.0f}, {}});
  const Acquired a = acquire_one(s, geometry);
  test::SpectrumFft fft(n);
  int shadowed = 0;
  int clear = 0;
  for (std::uint32_t r = 0; r < ascans; ++r) {
    // Each A-scan's own mean as its background: the group's mean would carry a residue of the
    // other A-scans' layers (1 / sqrt(128) of them) into the shadow.
    const auto own = fft.magnitude(record(a, r, n));
    const Magnitude magnitude(own.begin(), own.end());
    const float noise = test::median_magnitude(magnitude, n / 2 - 100, n / 2);
    const std::uint32_t rpe = test::peak_near(magnitude, a.truth.rpe_px[r], 1);
    if (std::isfinite(a.truth.tool_px[r])) {
      ++shadowed;
      const std::uint32_t tool = test::peak_near(magnitude, a.truth.tool_px[r], 1);
      EXPECT_GT(magnitude[tool], 20.0f * noise) << r;
      EXPECT_LT(magnitude[rpe], 4.0f * noise) << "the RPE under the tool is in its shadow " << r;
    } else if (a.truth.beam_x[r] > 0.15f) {
      ++clear;
      EXPECT_GT(magnitude[rpe], 20.0f * noise) << r;
    }
  }
  EXPECT_GT(shadowed, 30);
  EXPECT_GT(clear, 30);
}

TEST(Physics, AnteriorSegmentShowsCorneaIrisShadowAndLens) {
  const std::uint32_t n = 2752;  // 7.7 mm: the whole chamber
  const std::uint32_t ascans = 128;
  const hal::DigitizerConfig geometry = line_geometry(n, ascans);
  SimulationConfig s;
  s.preset = SamplePreset::anterior_segment;
  s.scan.ascans_per_bscan = ascans;
  s.scan.bscans_per_volume = 1;
  s.scan.extent_y = 0.0f;
  const Acquired a = acquire_one(s, geometry);
  const AnteriorSegmentModel model(s.anterior, s.source.axial_pixel_um(), n / 2);
  test::SpectrumFft fft(n);
  int pupil = 0;
  int iris = 0;
  for (std::uint32_t r = 0; r < ascans; ++r) {
    const AnteriorColumn c = model.column({a.truth.beam_x[r], a.truth.beam_y[r]});
    if (!std::isfinite(c.lens_px)) continue;
    const auto own = fft.magnitude(record(a, r, n));  // own mean: nothing of other A-scans
    const Magnitude magnitude(own.begin(), own.end());
    const float noise = test::median_magnitude(magnitude, 8, n / 2);
    EXPECT_GT(magnitude[test::peak_near(magnitude, c.epithelium_px, 2)], 10.0f * noise) << r;
    EXPECT_GT(magnitude[test::peak_near(magnitude, c.endothelium_px, 2)], 5.0f * noise) << r;
    const float lens = magnitude[test::peak_near(magnitude, c.lens_px, 2)];
    if (std::isfinite(c.iris_front_px)) {
      if (c.lens_px - c.iris_back_px < 10.0f) continue;  // at the pupil margin they touch
      ++iris;
      EXPECT_GT(magnitude[test::peak_near(magnitude, c.iris_front_px, 2)], 10.0f * noise) << r;
      EXPECT_LT(lens, 4.0f * noise) << "the lens behind the iris is in its shadow " << r;
    } else {
      ++pupil;
      EXPECT_GT(lens, 5.0f * noise) << "the lens through the pupil " << r;
    }
  }
  EXPECT_GT(pupil, 20);
  EXPECT_GT(iris, 20);
}

TEST(Physics, MacularHoleAndMembraneShowWhereTheModelPutsThem) {
  const std::uint32_t n = 1376;
  const std::uint32_t ascans = 192;
  const hal::DigitizerConfig geometry = line_geometry(n, ascans);
  SimulationConfig s;
  s.retina.macular_hole.enabled = true;
  s.retina.membrane.enabled = true;
  s.retina.membrane.center_x = 0.06;  // over the fovea too, beside the hole
  s.retina.membrane.center_y = 0.0;
  s.scan.ascans_per_bscan = ascans;
  s.scan.bscans_per_volume = 1;
  s.scan.center_y = -0.04f;  // through the fovea
  s.scan.extent_y = 0.0f;
  const Acquired a = acquire_one(s, geometry);
  const RetinaModel model(s.retina, s.source.axial_pixel_um(), n / 2);
  test::SpectrumFft fft(n);
  int in_hole = 0;
  int membrane = 0;
  for (std::uint32_t r = 0; r < ascans; ++r) {
    const hal::BeamPosition beam{a.truth.beam_x[r], a.truth.beam_y[r]};
    const RetinaColumn c = model.column(beam);
    const auto own = fft.magnitude(record(a, r, n));  // own mean: nothing of other A-scans
    const Magnitude magnitude(own.begin(), own.end());
    const float noise = test::median_magnitude(magnitude, n / 2 - 100, n / 2);
    if (std::isnan(c.ilm_px)) {
      ++in_hole;
      EXPECT_TRUE(std::isnan(a.truth.ilm_px[r]));
      // Nothing between the vitreous and the RPE.
      const auto top = static_cast<std::uint32_t>(c.rpe_px - 40.0f);
      const auto bottom = static_cast<std::uint32_t>(c.rpe_px - 6.0f);
      for (std::uint32_t bin = top; bin < bottom; ++bin)
        EXPECT_LT(magnitude[bin], 6.0f * noise) << r;
      EXPECT_GT(magnitude[test::peak_near(magnitude, c.rpe_px, 1)], 20.0f * noise);
    } else if (std::isfinite(c.membrane_top_px) && c.ilm_px - c.membrane_bottom_px > 4.0f) {
      ++membrane;
      EXPECT_GT(magnitude[test::peak_near(magnitude, c.membrane_top_px, 1)], 10.0f * noise) << r;
    }
  }
  EXPECT_GT(in_hole, 5);
  EXPECT_GT(membrane, 5);
}

}  // namespace
}  // namespace ioct::sim
