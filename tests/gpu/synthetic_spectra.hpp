// Synthetic raw spectra for the gpu tests and benchmarks: what a k-clocked swept source and a
// 12-bit digitizer deliver, reduced to what the processing chain must cope with.
//
//   sample(s) = dc + pattern * envelope(s)                      background, the same every sweep
//             + envelope(s) * sum_r A_r cos(2 pi f_r s / N + phi) interference of each reflector
//             + noise                                           white, sigma counts
//
// A reflector at depth bin f (f cycles over the sweep) must come out at depth pixel f. The phase
// phi is random per A-scan, as sample motion makes it, so the fringes average out of the group's
// mean spectrum while the background does not.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <span>
#include <vector>

#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu::testing {

struct Reflector {
  double depth_bin = 0.0;  // cycles per sweep
  double amplitude = 0.0;  // ADC counts at the envelope's peak
};

struct SpectrumModel {
  std::uint32_t samples = 0;
  double dc = 2048.0;      // mid-level of the 12-bit digitizer
  double pattern = 600.0;  // source spectrum height above dc
  double noise_sigma = 2.0;
};

class SpectrumSynthesizer {
 public:
  SpectrumSynthesizer(SpectrumModel model, std::uint32_t seed);

  // One spectrum of model.samples 12-bit values (clamped to 0..4095).
  void fill(std::span<std::uint16_t> spectrum, std::span<const Reflector> reflectors);

  const SpectrumModel& model() const noexcept { return model_; }

 private:
  SpectrumModel model_;
  std::vector<double> envelope_;
  std::mt19937 rng_;
};

// The reflectors of record `record` (0 = first recorded A-scan) of the group's B-scan `bscan`.
using ReflectorsOf =
    std::function<std::vector<Reflector>(std::uint32_t bscan, std::uint32_t record)>;

// Fills a whole group's payload [bscan][record][sample].
void fill_group(const shm::RingGeometry& geometry, SpectrumSynthesizer& synthesizer,
                const ReflectorsOf& reflectors, std::span<std::uint16_t> payload);

// Marker of B-scan `bscan_in_volume` of volume `volume`: flags start/end at the volume's ends,
// reversed when `bidirectional` and the B-scan index is odd.
shm::BscanMarker marker_for(std::uint64_t volume, std::uint32_t bscan_in_volume,
                            std::uint32_t bscans_per_volume, bool bidirectional);

}  // namespace ioct::gpu::testing
