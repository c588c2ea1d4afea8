// Optional lambda -> k resampling, for spectrometers and swept sources without a k-clock: the
// raw samples are not evenly spaced in wavenumber, and a calibration polynomial says where, in
// the raw sweep, each k-linear sample lies.
//
// Calibration: output (k-linear) sample j of N is read at raw position
//     x(j) = (N - 1) * (c0 + c1 t + c2 t^2 + ... ),   t = j / (N - 1)
// in raw samples, so {0, 1} is the identity, whatever N. x must increase strictly over the sweep
// and stay inside it (0 <= x <= N - 1); prepare() checks that for the geometry's N and throws
// ConfigError("resampling_coefficients", ...) saying where it fails.
//
// Interpolation between raw samples: linear (2 taps) or cubic convolution (Keys, a = -0.5, 4
// taps, exact for quadratics), with the sweep's end samples repeated past its ends. The taps and
// weights are tabulated once, in double precision rounded to float, and both the CPU and the
// CUDA chains read that one table.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ioct::gpu {

enum class Interpolation {
  none,    // samples are already linear in k (k-clock): no resampling
  linear,  // 2 taps
  cubic,   // 4 taps, cubic convolution
};

std::string_view to_string(Interpolation interpolation) noexcept;
// Throws ConfigError("resampling", ...) naming the accepted values.
Interpolation parse_interpolation(std::string_view text);

struct ResamplingConfig {
  Interpolation interpolation = Interpolation::none;
  std::vector<double> coefficients{0.0, 1.0};  // c0, c1, ... of x(t) / (N - 1)

  bool enabled() const noexcept { return interpolation != Interpolation::none; }
  // Throws ConfigError: 1 to 8 coefficients, each finite (the key names the index, e.g.
  // "resampling_coefficients[2]").
  void validate() const;
  // Also checks the calibration against a sweep of `samples`: x strictly increasing, inside
  // [0, samples - 1]. Throws ConfigError("resampling_coefficients", ...).
  void validate_for(std::uint32_t samples) const;
};

// The resampling the command-line tools (ioct-gpu, ioct-process, ioct-dispersion) choose, one rule
// for all: `interpolation` as given ("none", "linear", "cubic"); when empty, cubic if a calibration
// was given and none otherwise (a calibration given is meant to be used). A resampling asked for
// without a calibration is refused: ConfigError("resample", ...).
ResamplingConfig choose_resampling(std::string_view interpolation,
                                   const std::vector<double>* calibration);

// "0,1,-0.02" -> {0, 1, -0.02}. Throws ConfigError("resampling_coefficients", ...) for text that
// is not a comma-separated list of numbers.
std::vector<double> parse_coefficients(std::string_view text);
std::string format_coefficients(const std::vector<double>& coefficients);

// Raw position x(j) of output sample j (see above).
double calibration_position(const std::vector<double>& coefficients, std::uint32_t samples,
                            std::uint32_t j) noexcept;

// Output sample j = sum over t < taps of weight[j * taps + t] * raw[first[j] + t].
struct ResamplingTable {
  std::uint32_t taps = 0;  // 0: no resampling
  std::vector<std::uint32_t> first;
  std::vector<float> weights;
};

// The table for `config` and a sweep of `samples` (validated with validate_for()).
ResamplingTable make_resampling_table(const ResamplingConfig& config, std::uint32_t samples);

}  // namespace ioct::gpu
