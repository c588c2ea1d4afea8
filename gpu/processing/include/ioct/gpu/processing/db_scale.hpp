// Log magnitude and the u8 display mapping.
//
// The FFT of a windowed fringe is scaled by 2 / sum(window), so the value at a depth is the
// fringe's amplitude in ADC counts: a layer whose fringe swings +-A counts around the background
// reads 20 log10(A) dB whatever the window and the number of samples. A pixel is then
//   u8 = 255 * clamp((dB - db_min) / (db_max - db_min), 0, 1)
// so db_min is the darkest level shown (set it just above the noise floor) and db_max the level
// that saturates.
//
// The defaults suit 12-bit k-clock spectra of 1376 samples. White noise of sigma counts per
// sample lands at 10 log10(6 sigma^2 / N) dB after the Hann window: -11.6 dB for sigma = 4 (read
// plus shot noise of a balanced detector at mid-scale), and its speckle-like tail stays below
// 0 dB in all but about 1 pixel in 10^6, so db_min = 0 dB keeps the noise floor black. 0 dB is
// also a fringe of one ADC count, the faintest layer worth showing; 40 dB is 100 counts, so a
// strong layer (the RPE, some tens of counts) is bright and only its speckle peaks saturate.
#pragma once

#include <complex>
#include <cstdint>
#include <string_view>

#include "ioct/gpu/processing/host_device.hpp"

namespace ioct::gpu {

struct DbScaleConfig {
  double db_min = 0.0;   // dB shown black: a fringe of 1 ADC count
  double db_max = 40.0;  // dB shown white: a fringe of 100 ADC counts
  // Throws ConfigError: each in [-200, 300] dB, db_max - db_min >= 1 dB. Keys are named
  // "db_min", "db_max", or "<prefix>.db_min" ... with a prefix (e.g. "processing").
  void validate(std::string_view prefix = {}) const;
};

// Maps FFT bins to u8 pixels. Cheap to copy; one per processor.
class DbToU8 {
 public:
  // window_sum: sum of the window's coefficients (N for no window, about N/2 for Hann).
  DbToU8(const DbScaleConfig& config, double window_sum);

  // dB of one unnormalised FFT bin of power |X|^2 (20 log10 of the fringe amplitude).
  double db_of_power(double power) const;

  std::uint8_t pixel(float power) const noexcept {
    return clamp_level(gain_ * log2_of(power) + offset_);
  }

  // Pixels of `count` bins.
  void map_row(const std::complex<float>* bins, std::uint8_t* out,
               std::uint32_t count) const noexcept;
  // Pixels of `count` powers |X|^2 (the mean power of repeated B-scans).
  void map_power_row(const float* power, std::uint8_t* out, std::uint32_t count) const noexcept;

  // The shared host/device definitions (host_device.hpp), under the names the CPU code uses.
  static float log2_of(float x) noexcept { return fast_log2(x); }

  // The mapping as two numbers, for the CUDA kernels: pixel = level_to_u8(gain * log2(power) +
  // offset).
  float gain() const noexcept { return gain_; }
  float offset() const noexcept { return offset_; }

 private:
  static std::uint8_t clamp_level(float level) noexcept { return level_to_u8(level); }

  float gain_ = 0.0f;    // u8 units per unit of log2(power)
  float offset_ = 0.0f;  // u8 value at power 1
  double norm_db_ = 0.0;
  double db_min_ = 0.0;
};

}  // namespace ioct::gpu
