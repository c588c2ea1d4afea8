// The simulated galvo output and its mirrors: the FIFO's books (written, output, fill,
// underruns), park and lead compensation, the mirrors' second-order response, and what that does
// to the image: forward and reverse lines of a bidirectional raster misregistered by the
// mirrors' lag (measured on a tilted mirror, whose depth tells where the beam was), which lead
// compensation removes; a short flyback that leaves the start of each line off target.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include "ioct/scan/scan_builder.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulated_galvo_output.hpp"
#include "spectrum_fft.hpp"

namespace ioct::sim {
namespace {

hal::GalvoOutputConfig output_config(std::uint32_t capacity, std::uint32_t lead = 0) {
  hal::GalvoOutputConfig config;
  config.fifo_capacity = capacity;
  config.lead_samples = lead;
  return config;
}

std::vector<hal::GalvoSample> ramp(std::size_t count, float step) {
  std::vector<hal::GalvoSample> samples(count);
  for (std::size_t i = 0; i < count; ++i) samples[i] = {step * static_cast<float>(i), 0.0f};
  return samples;
}

TEST(SimulatedGalvo, FifoKeepsItsBooksAndCountsEachDrySpellOnce) {
  auto bench = std::make_shared<SimulatedBench>();
  SimulatedGalvoOutput galvo(bench);
  galvo.prepare(output_config(64));
  EXPECT_TRUE(galvo.status().parked);
  const std::vector<hal::GalvoSample> samples = ramp(100, 0.001f);
  EXPECT_EQ(galvo.write(samples), 64u) << "no more than the FIFO holds";
  EXPECT_EQ(galvo.status().fifo_fill, 64u);
  bench->scanner().advance(10, true, nullptr);
  EXPECT_EQ(galvo.status().samples_output, 0u) << "nothing is clocked out before start()";

  galvo.start();
  EXPECT_FALSE(galvo.status().parked);
  bench->scanner().advance(10, true, nullptr);
  hal::GalvoStatus status = galvo.status();
  EXPECT_EQ(status.samples_output, 10u);
  EXPECT_EQ(status.fifo_fill, 54u);
  EXPECT_EQ(status.samples_written, 64u);
  EXPECT_EQ(status.underruns, 0u);
  EXPECT_EQ(status.faults, 0u);

  bench->scanner().advance(60, true, nullptr);  // runs dry after 54
  status = galvo.status();
  EXPECT_EQ(status.samples_output, 64u);
  EXPECT_EQ(status.underruns, 1u);
  EXPECT_EQ(status.faults, hal::kGalvoUnderrun);
  EXPECT_EQ(galvo.write(std::span(samples).first(5)), 5u);
  bench->scanner().advance(10, true, nullptr);
  EXPECT_EQ(galvo.status().underruns, 2u) << "a second dry spell";
  EXPECT_EQ(galvo.status().samples_output, 69u);
  // Sticky until the next start.
  galvo.stop();
  galvo.start();
  EXPECT_EQ(galvo.status().faults, 0u);
  EXPECT_EQ(galvo.status().underruns, 0u);
}

TEST(SimulatedGalvo, ParkDropsTheQueueAndTheMirrorsSettleAtThePark) {
  auto bench = std::make_shared<SimulatedBench>();
  SimulatedGalvoOutput galvo(bench);
  hal::GalvoOutputConfig config = output_config(256);
  config.park = {0.9f, -0.7f};
  galvo.prepare(config);
  galvo.write(std::vector<hal::GalvoSample>(200, hal::GalvoSample{0.0f, 0.0f}));
  galvo.start();
  bench->scanner().advance(100, true, nullptr);
  EXPECT_NEAR(bench->scanner().mirror().x, 0.0f, 1e-3f);
  galvo.park();
  const hal::GalvoStatus status = galvo.status();
  EXPECT_TRUE(status.parked);
  EXPECT_EQ(status.fifo_fill, 0u);
  EXPECT_EQ(galvo.state(), hal::GalvoOutput::State::prepared);
  bench->scanner().advance(300, true, nullptr);  // 3 ms at 100 kHz: well settled
  EXPECT_NEAR(bench->scanner().mirror().x, 0.9f, 1e-3f);
  EXPECT_NEAR(bench->scanner().mirror().y, -0.7f, 1e-3f);
  EXPECT_EQ(galvo.status().samples_output, 100u) << "nothing more is clocked out once parked";
}

TEST(SimulatedGalvo, LeadCompensationSkipsTheFirstSamples) {
  auto bench = std::make_shared<SimulatedBench>();
  SimulatedGalvoOutput galvo(bench);
  galvo.prepare(output_config(256, 7));
  galvo.write(ramp(100, 0.01f));
  galvo.start();
  bench->scanner().advance(1, true, nullptr);
  EXPECT_EQ(galvo.status().samples_output, 8u) << "7 samples belong to sweeps before the first";
  EXPECT_EQ(galvo.status().fifo_fill, 92u);
}

TEST(SimulatedGalvo, MirrorsFollowASecondOrderResponse) {
  BenchConfig config;
  config.mirrors = {2000.0, 0.5};
  auto bench = std::make_shared<SimulatedBench>(config);
  SimulatedGalvoOutput galvo(bench);
  galvo.prepare(output_config(4096));
  // From rest at 0 to a step of 0.5.
  galvo.write(std::vector<hal::GalvoSample>(50, hal::GalvoSample{0.0f, 0.0f}));
  galvo.write(std::vector<hal::GalvoSample>(400, hal::GalvoSample{0.5f, 0.0f}));
  galvo.start();
  std::vector<hal::BeamPosition> positions(450);
  bench->scanner().advance(450, true, positions.data());
  float peak = 0.0f;
  for (const hal::BeamPosition& p : positions) peak = std::max(peak, p.x);
  // Overshoot of a damped second-order system: exp(-zeta pi / sqrt(1 - zeta^2)).
  const double zeta = 0.5;
  const double overshoot = std::exp(-zeta * std::numbers::pi / std::sqrt(1.0 - zeta * zeta));
  EXPECT_NEAR(peak, 0.5 * (1.0 + overshoot), 0.002);
  EXPECT_NEAR(positions.back().x, 0.5f, 1e-4f);
  // Time to the peak: pi / (omega sqrt(1 - zeta^2)) = 289 us after the step, in sweeps of 10 us
  // (position at mid-sweep; the step is applied at sweep 50's start).
  const auto peak_sweep = std::max_element(positions.begin(), positions.end(),
                                           [](auto a, auto b) { return a.x < b.x; }) -
                          positions.begin();
  const double t_peak =
      std::numbers::pi / (2.0 * std::numbers::pi * 2000.0 * std::sqrt(1.0 - zeta * zeta));
  EXPECT_NEAR(static_cast<double>(peak_sweep - 50) + 0.5, t_peak * 1e5, 1.0);
}

// Where the beam was, from the image: the tilted mirror's depth is linear in x.
struct MirrorReading {
  double depth_fraction;
  double tilt;
  double x(double depth_px, double depth_bins) const {
    return (depth_px / depth_bins - depth_fraction) / tilt;
  }
};

struct BidirectionalRun {
  std::vector<double> measured_x;  // per record of the second group, from the image
  std::vector<float> truth_x;      // the beam's actual x from the truth
  std::vector<float> commanded_x;
  std::uint32_t ascans;
  std::uint32_t bscans;
};

BidirectionalRun run_raster(bool bidirectional, std::uint32_t lead, std::uint32_t flyback,
                            double natural_hz = 2000.0) {
  const std::uint32_t n = 512;
  const std::uint32_t ascans = 128;
  hal::DigitizerConfig geometry;
  geometry.samples_per_ascan = n;
  geometry.ascans_per_bscan = ascans;
  geometry.flyback_sweeps = flyback;
  geometry.bscans_per_group = 8;
  SimulationConfig s;
  s.preset = SamplePreset::mirror;
  s.mirror.depth_fraction = 0.5;
  s.mirror.tilt_x_fraction = 0.3;
  s.scan.ascans_per_bscan = ascans;
  s.scan.bscans_per_volume = 8;
  s.scan.extent_x = 0.8f;
  s.scan.extent_y = 0.5f;
  s.bench.mirrors.natural_hz = natural_hz;  // damping 0.7
  auto bench = std::make_shared<SimulatedBench>(s.bench);
  SimulatedGalvoOutput galvo(bench);
  SimulatedDigitizer digitizer(s, bench);
  digitizer.prepare(geometry);
  // Planned as ioct-rt plans a scan, within limits loose enough for the short flybacks these
  // tests give the simulated mirrors on purpose.
  const scan::ScanPattern waveform = scan::plan_raster(
      s.scan, geometry, bidirectional ? scan::ScanKind::bidirectional : scan::ScanKind::raster,
      scan::GalvoLimits{1e7, 1e13});
  const std::uint64_t sweeps = 3 * geometry.sweeps_per_group();
  std::vector<hal::GalvoSample> samples(sweeps);
  waveform.fill(0, samples);
  galvo.prepare(output_config(static_cast<std::uint32_t>(sweeps), lead));
  EXPECT_EQ(galvo.write(samples), sweeps);
  galvo.start();
  digitizer.start();
  std::vector<std::uint16_t> group(geometry.samples_per_group());
  hal::GroupInfo info;
  digitizer.acquire_group(group, info);  // the mirrors start at the park: let them settle
  digitizer.acquire_group(group, info);
  const GroupTruth& truth = digitizer.last_group_truth();
  const std::vector<double> background = test::mean_spectrum(group, n);
  test::SpectrumFft fft(n);
  const MirrorReading reading{0.5, 0.3};
  BidirectionalRun run;
  run.ascans = ascans;
  run.bscans = geometry.bscans_per_group;
  for (std::size_t r = 0; r < truth.ascans(); ++r) {
    const auto magnitude =
        fft.magnitude(std::span<const std::uint16_t>(group).subspan(r * n, n), background);
    std::uint32_t peak = 40;  // past the DC and fixed-pattern bins
    for (std::uint32_t bin = 40; bin < n / 2 - 1; ++bin) {
      if (magnitude[bin] > magnitude[peak]) peak = bin;
    }
    run.measured_x.push_back(reading.x(test::interpolated_peak(magnitude, peak), n / 2));
    run.truth_x.push_back(truth.beam_x[r]);
    const std::uint64_t sweep =
        info.first_sweep_counter + (r / ascans) * geometry.sweeps_per_bscan() + r % ascans;
    run.commanded_x.push_back(waveform.at(sweep).x);
  }
  return run;
}

// Mean of forward-minus-reverse x at the same commanded positions, over the middle half of
// the lines (away from the turnarounds).
double misregistration(const BidirectionalRun& run, const std::vector<double>& x) {
  double sum = 0.0;
  int count = 0;
  for (std::uint32_t b = 0; b + 1 < run.bscans; b += 2) {  // even lines forward, odd reversed
    for (std::uint32_t a = run.ascans / 4; a < 3 * run.ascans / 4; ++a) {
      const std::size_t forward = std::size_t{b} * run.ascans + a;
      const std::size_t reverse = std::size_t{b + 1} * run.ascans + (run.ascans - 1 - a);
      EXPECT_NEAR(run.commanded_x[forward], run.commanded_x[reverse], 1e-6);
      sum += x[forward] - x[reverse];
      ++count;
    }
  }
  return sum / count;
}

TEST(SimulatedGalvo, BidirectionalLinesAreMisregisteredByTheMirrorsLag) {
  const BidirectionalRun run = run_raster(true, 0, 8);
  const double measured = misregistration(run, run.measured_x);
  std::vector<double> truth(run.truth_x.begin(), run.truth_x.end());
  const double from_truth = misregistration(run, truth);
  // A ramp of speed v lags by 2 zeta / omega: forward lines lag left, reverse lines right.
  const double v = 2.0 * 0.8 / (run.ascans - 1) * 100'000.0;  // scan units per second
  const double lag_s = 2.0 * 0.7 / (2.0 * std::numbers::pi * 2000.0);
  const double expected = -2.0 * v * lag_s;
  std::printf(
      "[ galvo    ] forward - reverse: %.4f scan units from the image, %.4f from the "
      "truth, %.4f expected (%.1f A-scans)\n",
      measured, from_truth, expected, expected / (1.6 / (run.ascans - 1)));
  EXPECT_NEAR(measured, expected, 0.05 * std::abs(expected));
  EXPECT_NEAR(measured, from_truth, 0.005);
  // Lead compensation by the lag in sweeps removes most of it.
  const BidirectionalRun led =
      run_raster(true, static_cast<std::uint32_t>(std::lround(lag_s * 1e5)), 8);
  const double compensated = misregistration(led, led.measured_x);
  EXPECT_LT(std::abs(compensated), 0.1 * std::abs(expected));
  // Ideal mirrors (natural_hz = 0) are where commanded.
  const BidirectionalRun ideal = run_raster(true, 0, 8, 0.0);
  EXPECT_LT(std::abs(misregistration(ideal, ideal.measured_x)), 0.01);
  for (std::size_t r = 0; r < ideal.truth_x.size(); ++r) {
    ASSERT_EQ(ideal.truth_x[r], ideal.commanded_x[r]) << r;
  }
}

TEST(SimulatedGalvo, AShortFlybackLeavesTheStartOfEachLineOffTarget) {
  const BidirectionalRun run = run_raster(false, 0, 4);  // 40 us to fly back 1.6 units
  const double lag = 2.0 * 0.8 / 127.0 * 1e5 * 2.0 * 0.7 / (2.0 * std::numbers::pi * 2000.0);
  for (std::uint32_t b = 0; b < run.bscans; ++b) {
    const std::size_t first = std::size_t{b} * run.ascans;
    const std::size_t middle = first + run.ascans / 2;
    // The mirror is still on its way back when the line starts...
    EXPECT_GT(run.truth_x[first] - run.commanded_x[first], 0.5) << b;
    EXPECT_NEAR(run.measured_x[first], run.truth_x[first], 0.01) << b;
    // ... and has caught up with the ramp, one lag behind, by mid-line.
    EXPECT_NEAR(run.commanded_x[middle] - run.truth_x[middle], lag, 0.1 * lag) << b;
  }
}

}  // namespace
}  // namespace ioct::sim
