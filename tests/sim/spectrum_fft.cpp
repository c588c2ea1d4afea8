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
      magnitude_(samples / 2) {
  if (plan_ == nullptr) throw std::runtime_error("fftwf_plan_dft_r2c_1d failed");
}

SpectrumFft::~SpectrumFft() {
  fftwf_destroy_plan(plan_);
  fftwf_free(output_);
  fftwf_free(input_);
}

std::span<const float> SpectrumFft::magnitude(std::span<const std::uint16_t> spectrum) {
  if (spectrum.size() != samples_) throw std::invalid_argument("spectrum of the wrong length");
  double sum = 0.0;
  for (std::uint16_t value : spectrum) sum += value;
  const double mean = sum / samples_;
  for (std::uint32_t i = 0; i < samples_; ++i) {
    input_[i] = static_cast<float>(spectrum[i] - mean);
  }
  fftwf_execute(plan_);
  for (std::uint32_t bin = 0; bin < magnitude_.size(); ++bin) {
    magnitude_[bin] = std::hypot(output_[bin][0], output_[bin][1]);
  }
  return magnitude_;
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

}  // namespace ioct::test
