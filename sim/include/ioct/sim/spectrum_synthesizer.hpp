// One k-clocked spectrum as the ADC delivers it: detector background, additive noise and the
// fringes of a set of reflectors, quantised to the ADC's range.
//
// Everything is tabulated when it is built; synthesize() only adds table rows and does not
// allocate. Noise comes from a table of standard-normal values read at two random offsets per
// spectrum (the sum of two windows keeps neighbouring spectra from sharing a noise pattern).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ioct/sim/detector.hpp"
#include "ioct/sim/fringe_tables.hpp"
#include "ioct/sim/swept_source.hpp"

namespace ioct::sim {

struct Reflector {
  TableDepth depth;
  float amplitude = 0.0f;  // fringe amplitude at the envelope peak, ADC counts
};

class SpectrumSynthesizer {
 public:
  static constexpr std::uint32_t kNoiseOffsets = 1u << 16;

  // Throws std::invalid_argument for a sample count FringeTables cannot hold.
  SpectrumSynthesizer(const SweptSourceConfig& source, const DetectorConfig& detector,
                      std::uint32_t samples, std::uint32_t sample_bits, std::uint64_t noise_seed);

  const FringeTables& fringes() const noexcept { return fringes_; }
  std::uint32_t samples() const noexcept { return fringes_.samples(); }

  // Writes one spectrum of samples() words to `out`. noise_a and noise_b are offsets in
  // [0, kNoiseOffsets).
  void synthesize(std::span<const Reflector> reflectors, std::uint32_t noise_a,
                  std::uint32_t noise_b, std::uint16_t* out) noexcept;

 private:
  FringeTables fringes_;
  std::vector<float> background_;   // [i] counts
  std::vector<float> noise_sigma_;  // [i] counts
  std::vector<float> noise_;        // standard normal / sqrt(2), kNoiseOffsets + N values
  std::vector<float> accumulator_;  // [i] the spectrum being built
  float max_value_ = 0.0f;
};

}  // namespace ioct::sim
