// What a reader of the raw spectra does first, as plainly as possible, to check where the
// simulator put things: background removal (the A-scan's own mean, or the group's mean
// spectrum), a plain FFT, magnitudes of bins [0, N/2); plus peak measures.
#pragma once

#include <fftw3.h>

#include <complex>
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
  // |FFT(spectrum - background)| at depth bins [0, N/2).
  std::span<const float> magnitude(std::span<const std::uint16_t> spectrum,
                                   std::span<const double> background);
  // |FFT(x)| of a real sequence, bins [0, N/2).
  std::span<const float> magnitude_of(std::span<const double> x);
  // |complex FFT(x)| of a complex sequence, bins [0, N/2) (positive depths).
  std::span<const float> magnitude_of(std::span<const std::complex<double>> x);

 private:
  std::uint32_t samples_;
  float* input_;
  fftwf_complex* output_;
  fftwf_plan plan_;
  fftwf_complex* complex_input_;
  fftwf_complex* complex_output_;
  fftwf_plan complex_plan_;
  std::vector<float> magnitude_;
};

// The group's mean spectrum: the background a processing chain subtracts.
std::vector<double> mean_spectrum(std::span<const std::uint16_t> group, std::uint32_t samples);

// The bin of the largest magnitude within `radius` bins of `center`.
std::uint32_t peak_near(std::span<const float> magnitude, float center, std::uint32_t radius);

// Sub-bin position of the peak at `bin`: a parabola through the log magnitudes of it and its
// neighbours (exact for a Gaussian peak, which a Gaussian spectral envelope gives).
double interpolated_peak(std::span<const float> magnitude, std::uint32_t bin);

// Median magnitude over [begin, end): the noise floor where few bins hold reflectors.
float median_magnitude(std::span<const float> magnitude, std::size_t begin, std::size_t end);

// Full width at half maximum of the peak at `bin`, bins (linear between bins).
double peak_fwhm(std::span<const float> magnitude, std::uint32_t bin);

// Root of the summed power within `radius` bins of `bin`: a peak's amplitude independent of
// where between bins it falls.
double peak_energy(std::span<const float> magnitude, std::uint32_t bin, std::uint32_t radius);

}  // namespace ioct::test
