// The dB mapping: 20 log10 of the fringe amplitude, clamped to [db_min, db_max] -> [0, 255].
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

#include "ioct/gpu/processing/db_scale.hpp"

namespace ioct::gpu {
namespace {

constexpr double kWindowSum = 688.0;  // a Hann window of 1376 samples sums to about N/2

// The FFT power of a fringe of `amplitude` counts: |X| = amplitude * sum(w) / 2.
double power_of_amplitude(double amplitude) {
  const double magnitude = amplitude * kWindowSum / 2.0;
  return magnitude * magnitude;
}

double power_at_db(double db) {
  return power_of_amplitude(std::pow(10.0, db / 20.0));
}

TEST(DbToU8, DbIsTwentyLogOfTheFringeAmplitude) {
  const DbToU8 scale(DbScaleConfig{}, kWindowSum);
  EXPECT_NEAR(scale.db_of_power(power_of_amplitude(1.0)), 0.0, 1e-9);
  EXPECT_NEAR(scale.db_of_power(power_of_amplitude(100.0)), 40.0, 1e-9);
}

TEST(DbToU8, ClampsBelowDbMinAndAboveDbMax) {
  const DbScaleConfig config{10.0, 50.0};
  const DbToU8 scale(config, kWindowSum);
  EXPECT_EQ(scale.pixel(0.0f), 0);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(-40.0))), 0);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(9.9))), 0);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(10.1))), 1);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(30.1))), 128);  // 128.14
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(49.9))), 254);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(50.1))), 255);
  EXPECT_EQ(scale.pixel(static_cast<float>(power_at_db(120.0))), 255);
  EXPECT_EQ(scale.pixel(3e38f), 255);
}

TEST(DbToU8, IsMonotonicAndMapRowAgreesWithPixel) {
  const DbToU8 scale(DbScaleConfig{}, kWindowSum);
  std::vector<std::complex<float>> bins;
  for (double db = -30.0; db <= 70.0; db += 0.05) {
    const double magnitude = std::sqrt(power_at_db(db));
    bins.emplace_back(static_cast<float>(magnitude * 0.6), static_cast<float>(magnitude * 0.8));
  }
  bins.emplace_back(0.0f, 0.0f);
  std::vector<std::uint8_t> row(bins.size());
  scale.map_row(bins.data(), row.data(), static_cast<std::uint32_t>(bins.size()));
  for (std::size_t i = 0; i < bins.size(); ++i) {
    const float power = bins[i].real() * bins[i].real() + bins[i].imag() * bins[i].imag();
    EXPECT_EQ(row[i], scale.pixel(power)) << "bin " << i;
    if (i > 0 && i + 1 < bins.size()) {
      EXPECT_GE(row[i], row[i - 1]) << "bin " << i;
    }
  }
  EXPECT_EQ(row.front(), 0);
  EXPECT_EQ(row[row.size() - 2], 255);
  EXPECT_EQ(row.back(), 0);
}

TEST(DbToU8, FastLog2IsAccurateOverTheFloatRange) {
  double worst = 0.0;
  for (double x = 1e-30; x < 1e30; x *= 1.0137) {
    const float f = static_cast<float>(x);
    worst = std::max(worst, std::abs(DbToU8::log2_of(f) - std::log2(static_cast<double>(f))));
  }
  EXPECT_LT(worst, 3e-5);  // a u8 step is 0.06 in log2 at the default range
}

}  // namespace
}  // namespace ioct::gpu
