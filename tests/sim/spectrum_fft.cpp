#include "spectrum_fft.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ioct::test {

SpectrumFft::SpectrumFft(std::uint32_t samples)
    : samples_(samples),
      input_(fftwf_alloc_real(samples)),
      output_(fftwf_alloc_complex(samples / 2 + 1)),
      plan_(fftwf_plan_dft_r2c_1d(static_cast<int>(samples), input_, output_, FFTW_ESTIMATE)),
      complex_input_(fftwf_alloc_complex(samples)),
      complex_output_(fftwf_alloc_complex(samples)),
      complex_plan_(fftwf_plan_dft_1d(static_cast<int>(samples), complex_input_, complex_output_,
                                      FFTW_FORWARD, FFTW_ESTIMATE)),
      magnitude_(samples / 2) {
  if (plan_ == nullptr || complex_plan_ == nullptr)
    throw std::runtime_error("FFTW planning failed");
}

SpectrumFft::~SpectrumFft() {
  fftwf_destroy_plan(plan_);
  fftwf_destroy_plan(complex_plan_);
  fftwf_free(output_);
  fftwf_free(input_);
  fftwf_free(complex_input_);
  fftwf_free(complex_output_);
}

std::span<const float> SpectrumFft::magnitude(std::span<const std::uint16_t> spectrum) {
  if (spectrum.size() != samples_) throw std::invalid_argument("spectrum of the wrong length");
  double sum = 0.0;
  for (std::uint16_t value : spectrum) sum += value;
  std::vector<double> background(samples_, sum / samples_);
  return magnitude(spectrum, background);
}

std::span<const float> SpectrumFft::magnitude(std::span<const std::uint16_t> spectrum,
                                              std::span<const double> background) {
  if (spectrum.size() != samples_ || background.size() != samples_) {
    throw std::invalid_argument("spectrum of the wrong length");
  }
  std::vector<double> x(samples_);
  for (std::uint32_t i = 0; i < samples_; ++i) x[i] = spectrum[i] - background[i];
  return magnitude_of(x);
}

std::span<const float> SpectrumFft::magnitude_of(std::span<const double> x) {
  if (x.size() != samples_) throw std::invalid_argument("sequence of the wrong length");
  for (std::uint32_t i = 0; i < samples_; ++i) input_[i] = static_cast<float>(x[i]);
  fftwf_execute(plan_);
  for (std::uint32_t bin = 0; bin < magnitude_.size(); ++bin) {
    magnitude_[bin] = std::hypot(output_[bin][0], output_[bin][1]);
  }
  return magnitude_;
}

std::span<const float> SpectrumFft::magnitude_of(std::span<const std::complex<double>> x) {
  if (x.size() != samples_) throw std::invalid_argument("sequence of the wrong length");
  for (std::uint32_t i = 0; i < samples_; ++i) {
    complex_input_[i][0] = static_cast<float>(x[i].real());
    complex_input_[i][1] = static_cast<float>(x[i].imag());
  }
  fftwf_execute(complex_plan_);
  // The positive-depth part of a fringe, exp(+i 2 pi j z / N), is at bin z of the forward FFT.
  for (std::uint32_t bin = 0; bin < magnitude_.size(); ++bin) {
    magnitude_[bin] = std::hypot(complex_output_[bin][0], complex_output_[bin][1]);
  }
  return magnitude_;
}

std::vector<double> mean_spectrum(std::span<const std::uint16_t> group, std::uint32_t samples) {
  std::vector<double> mean(samples, 0.0);
  const std::size_t records = group.size() / samples;
  for (std::size_t r = 0; r < records; ++r) {
    for (std::uint32_t i = 0; i < samples; ++i) mean[i] += group[r * samples + i];
  }
  for (double& m : mean) m /= static_cast<double>(records);
  return mean;
}

std::uint32_t peak_near(std::span<const float> magnitude, float center, std::uint32_t radius) {
  const auto middle = static_cast<std::int64_t>(std::lround(center));
  const std::int64_t first = std::max<std::int64_t>(0, middle - radius);
  const std::int64_t last =
      std::min<std::int64_t>(static_cast<std::int64_t>(magnitude.size()) - 1, middle + radius);
  std::int64_t best = first;
  for (std::int64_t bin = first; bin <= last; ++bin) {
    if (magnitude[bin] > magnitude[best]) best = bin;
  }
  return static_cast<std::uint32_t>(best);
}

double interpolated_peak(std::span<const float> magnitude, std::uint32_t bin) {
  if (bin == 0 || bin + 1 >= magnitude.size()) return bin;
  const double left = std::log(magnitude[bin - 1]);
  const double middle = std::log(magnitude[bin]);
  const double right = std::log(magnitude[bin + 1]);
  const double curvature = left - 2.0 * middle + right;
  return curvature == 0.0 ? bin : bin + 0.5 * (left - right) / curvature;
}

float median_magnitude(std::span<const float> magnitude, std::size_t begin, std::size_t end) {
  std::vector<float> values(magnitude.begin() + begin, magnitude.begin() + end);
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

double peak_fwhm(std::span<const float> magnitude, std::uint32_t bin) {
  const double half = 0.5 * magnitude[bin];
  const auto crossing = [&](int step) {
    std::int64_t i = bin;
    while (i + step >= 0 && i + step < static_cast<std::int64_t>(magnitude.size()) &&
           magnitude[i + step] > half) {
      i += step;
    }
    if (i + step < 0 || i + step >= static_cast<std::int64_t>(magnitude.size())) {
      return static_cast<double>(i);
    }
    // Linear between the last sample above half and the first below.
    const double above = magnitude[i];
    const double below = magnitude[i + step];
    return static_cast<double>(i) + step * (above - half) / (above - below);
  };
  return crossing(1) - crossing(-1);
}

double peak_energy(std::span<const float> magnitude, std::uint32_t bin, std::uint32_t radius) {
  double sum = 0.0;
  const std::int64_t first = std::max<std::int64_t>(0, static_cast<std::int64_t>(bin) - radius);
  const std::int64_t last = std::min<std::int64_t>(static_cast<std::int64_t>(magnitude.size()) - 1,
                                                   static_cast<std::int64_t>(bin) + radius);
  for (std::int64_t i = first; i <= last; ++i)
    sum += static_cast<double>(magnitude[i]) * magnitude[i];
  return std::sqrt(sum);
}

}  // namespace ioct::test
