#include "synthetic_spectra.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace ioct::gpu::testing {

SpectrumSynthesizer::SpectrumSynthesizer(SpectrumModel model, std::uint32_t seed)
    : model_(std::move(model)), rng_(seed) {
  for (std::uint32_t s = 0; s < model_.samples; ++s) {
    envelope_.push_back(envelope_at(model_.k_of_sample.empty() ? s : model_.k_of_sample[s]));
  }
}

double SpectrumSynthesizer::envelope_at(double k) const {
  // A Gaussian source spectrum centred on the sweep, 1/e half width a third of the sweep.
  const double centre = 0.5 * (model_.samples - 1);
  const double x = (k - centre) / (model_.samples / 3.0);
  return std::exp(-x * x);
}

void SpectrumSynthesizer::fill(std::span<std::uint16_t> spectrum,
                               std::span<const Reflector> reflectors) {
  std::normal_distribution<double> noise(0.0, model_.noise_sigma);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * std::numbers::pi);
  std::normal_distribution<double> standard(0.0, 1.0);
  const double power = model_.power_jitter > 0.0 ? 1.0 + model_.power_jitter * standard(rng_) : 1.0;
  const double line_gain =
      model_.fixed_pattern_jitter > 0.0 ? 1.0 + model_.fixed_pattern_jitter * standard(rng_) : 1.0;
  std::vector<double> phases;
  for (std::size_t r = 0; r < reflectors.size(); ++r) phases.push_back(phase(rng_));
  const double step = 2.0 * std::numbers::pi / model_.samples;
  for (std::uint32_t s = 0; s < model_.samples; ++s) {
    const double k = model_.k_of_sample.empty() ? s : model_.k_of_sample[s];
    const double envelope = envelope_[s];
    const double t = 2.0 * k / (model_.samples - 1) - 1.0;
    const double dispersion = (model_.c2 + model_.c3 * t) * t * t;
    double fixed = model_.fixed_pattern_amplitude * std::cos(step * model_.fixed_pattern_depth * k);
    for (const Reflector& line : model_.fixed_pattern_lines) {
      fixed += line.amplitude * std::cos(step * line.depth_bin * k);
    }
    double fringe = power * line_gain * fixed;
    for (std::size_t r = 0; r < reflectors.size(); ++r) {
      fringe += reflectors[r].amplitude *
                std::cos(step * reflectors[r].depth_bin * k + dispersion + phases[r]);
    }
    const double value =
        model_.dc + power * model_.pattern * envelope + envelope * fringe + noise(rng_);
    spectrum[s] = static_cast<std::uint16_t>(std::clamp(std::lround(value), 0L, 4095L));
  }
}

std::vector<double> k_of_raw_samples(const std::vector<double>& coefficients,
                                     std::uint32_t samples) {
  std::vector<double> k(samples);
  for (std::uint32_t s = 0; s < samples; ++s) {
    double lo = 0.0;  // bisection on the increasing x(k)
    double hi = samples - 1.0;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      const double t = mid / (samples - 1);
      double x = 0.0;
      for (std::size_t c = coefficients.size(); c-- > 0;) x = x * t + coefficients[c];
      (x * (samples - 1) < s ? lo : hi) = mid;
    }
    k[s] = 0.5 * (lo + hi);
  }
  return k;
}

void fill_group(const shm::RingGeometry& geometry, SpectrumSynthesizer& synthesizer,
                const ReflectorsOf& reflectors, std::span<std::uint16_t> payload) {
  const std::size_t samples = geometry.samples_per_ascan;
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    for (std::uint32_t r = 0; r < geometry.ascans_per_bscan; ++r) {
      const std::vector<Reflector> here = reflectors(b, r);
      synthesizer.fill(
          payload.subspan((std::size_t{b} * geometry.ascans_per_bscan + r) * samples, samples),
          here);
    }
  }
}

shm::BscanMarker marker_for(std::uint64_t volume, std::uint32_t bscan_in_volume,
                            std::uint32_t bscans_per_volume, bool bidirectional) {
  shm::BscanMarker marker{};
  marker.volume_index = volume;
  marker.bscan_in_volume = bscan_in_volume;
  if (bscan_in_volume == 0) marker.flags |= shm::kBscanVolumeStart;
  if (bscan_in_volume + 1 == bscans_per_volume) marker.flags |= shm::kBscanVolumeEnd;
  if (bidirectional && bscan_in_volume % 2 == 1) marker.flags |= shm::kBscanReversed;
  return marker;
}

}  // namespace ioct::gpu::testing
