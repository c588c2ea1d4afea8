#include "ioct/sim/spectrum_synthesizer.hpp"

#include <algorithm>
#include <cmath>

#include "ioct/sim/random.hpp"

namespace ioct::sim {

SpectrumSynthesizer::SpectrumSynthesizer(const SweptSourceConfig& source,
                                         const DetectorConfig& detector, std::uint32_t samples,
                                         std::uint32_t sample_bits, std::uint64_t noise_seed)
    : fringes_(source.envelope(samples)),
      accumulator_(samples),
      max_value_(static_cast<float>((1u << sample_bits) - 1u)) {
  const std::vector<float> envelope = source.envelope(samples);
  background_ = detector.background(envelope, sample_bits);
  noise_sigma_ = detector.noise_sigma(envelope, sample_bits);
  noise_.resize(std::size_t{kNoiseOffsets} + samples);
  Xoshiro256 rng(noise_seed);
  for (float& value : noise_) value = static_cast<float>(rng.normal() * std::sqrt(0.5));
}

void SpectrumSynthesizer::synthesize(std::span<const Reflector> reflectors, std::uint32_t noise_a,
                                     std::uint32_t noise_b,
                                     std::uint16_t* __restrict out) noexcept {
  const std::size_t n = samples();
  float* __restrict acc = accumulator_.data();
  const float* __restrict background = background_.data();
  const float* __restrict sigma = noise_sigma_.data();
  const float* __restrict noise_a_row = noise_.data() + noise_a;
  const float* __restrict noise_b_row = noise_.data() + noise_b;
  for (std::size_t i = 0; i < n; ++i) {
    acc[i] = background[i] + sigma[i] * (noise_a_row[i] + noise_b_row[i]);
  }
  // Two reflectors per pass over the spectrum: half the accumulator traffic.
  std::size_t r = 0;
  for (; r + 1 < reflectors.size(); r += 2) {
    fringes_.add_fringe_pair(acc, reflectors[r].depth, reflectors[r].amplitude,
                             reflectors[r + 1].depth, reflectors[r + 1].amplitude);
  }
  if (r < reflectors.size()) {
    fringes_.add_fringe(acc, reflectors[r].depth, reflectors[r].amplitude);
  }
  // The ADC: round to the nearest count and clip at its rails.
  const float top = max_value_;
  for (std::size_t i = 0; i < n; ++i) {
    const float clipped = std::min(std::max(acc[i], 0.0f), top);
    out[i] = static_cast<std::uint16_t>(static_cast<std::int32_t>(clipped + 0.5f));
  }
}

}  // namespace ioct::sim
