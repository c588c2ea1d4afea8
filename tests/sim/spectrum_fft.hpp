// The plain FFT a reader of the spectra would do first: remove the mean, real FFT of N samples,
// magnitude of bins [0, N/2). Used to check where the simulator put its reflectors.
#pragma once

#include <fftw3.h>

#include <cstdint>
#include <span>
#include <vector>

namespace ioct::test {

class SpectrumFft {
 public:
  explicit SpectrumFft(std::uint32_t samples);
  ~SpectrumFft();
  SpectrumFft(const SpectrumFft&) = delete;
  SpectrumFft& operator=(const SpectrumFft&) = delete;

  // |FFT(spectrum - mean)| at depth bins [0, N/2).
  std::span<const float> magnitude(std::span<const std::uint16_t> spectrum);

 private:
  std::uint32_t samples_;
  float* input_;
  fftwf_complex* output_;
  fftwf_plan plan_;
  std::vector<float> magnitude_;
};

// The bin of the largest magnitude within `radius` bins of `center`.
std::uint32_t peak_near(std::span<const float> magnitude, float center, std::uint32_t radius);

// Sub-bin position of the peak at `bin`: a parabola through the log magnitudes of it and its
// neighbours (exact for a Gaussian peak, which a Gaussian spectral envelope gives).
double interpolated_peak(std::span<const float> magnitude, std::uint32_t bin);

// Median magnitude over [begin, end): the noise floor where few bins hold reflectors.
float median_magnitude(std::span<const float> magnitude, std::size_t begin, std::size_t end);

}  // namespace ioct::test
