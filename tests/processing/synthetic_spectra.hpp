// Synthetic raw spectra for the gpu tests and benchmarks: what a k-clocked swept source and a
// 12-bit digitizer deliver, reduced to what the processing chain must cope with.
//
//   sample(s) = dc + g * pattern * envelope(k)                  background
//             + g * envelope(k) * sum_l F_l cos(2 pi f_l k / N)  fixed-pattern lines (optics)
//             + envelope(k) * sum_r A_r cos(2 pi f_r k / N + disp(k) + phi)   each reflector
//             + noise                                           white, sigma counts
// where g = 1 + power_jitter * n (n standard normal, drawn per sweep) is the source power of the
// sweep: with jitter, the mean spectrum no longer removes the background and the fixed pattern
// exactly, and a residue of them (DC and fixed-pattern lines) is left in every A-scan, as a
// spectrometer whose exposure or source power fluctuates leaves it. The lines also have their
// own factor 1 + fixed_pattern_jitter * n' (a reflection whose strength varies).
// where k = k(s) is the wavenumber (in k-linear sample units) at which raw sample s was taken:
// k = s for a k-clocked source, or a chirp given by `k_of_sample` for one that needs resampling;
// disp(k) = c2 t^2 + c3 t^3, t = 2 k / (N - 1) - 1, is a dispersion mismatch.
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
  double c2 = 0.0;  // dispersion mismatch, radians at the sweep's ends
  double c3 = 0.0;
  std::vector<double> k_of_sample{};  // empty: k = s (k-linear samples)
  // A reflection in the optics at this depth bin, the same phase in every sweep (0: none).
  double fixed_pattern_depth = 0.0;
  double fixed_pattern_amplitude = 0.0;
  // More such lines (depth bin, amplitude in ADC counts), on top of the one above.
  std::vector<Reflector> fixed_pattern_lines{};
  double power_jitter = 0.0;  // relative sigma of the source power from sweep to sweep
  // Relative sigma of the fixed-pattern lines' own strength from sweep to sweep, apart from the
  // power (a vibrating lens): a residue the background's shape cannot explain.
  double fixed_pattern_jitter = 0.0;
};

class SpectrumSynthesizer {
 public:
  SpectrumSynthesizer(SpectrumModel model, std::uint32_t seed);

  // One spectrum of model.samples 12-bit values (clamped to 0..4095).
  void fill(std::span<std::uint16_t> spectrum, std::span<const Reflector> reflectors);

  const SpectrumModel& model() const noexcept { return model_; }
  // The source envelope at wavenumber k (k-linear sample units), peak 1 mid-sweep.
  double envelope_at(double k) const;

 private:
  SpectrumModel model_;
  std::vector<double> envelope_;  // at each raw sample
  std::mt19937 rng_;
};

// The reflectors of record `record` (0 = first recorded A-scan) of the group's B-scan `bscan`.
using ReflectorsOf =
    std::function<std::vector<Reflector>(std::uint32_t bscan, std::uint32_t record)>;

// k_of_sample for a sweep that the chain's calibration `coefficients` (resampling.hpp) makes
// k-linear: raw sample s is taken at the k where the calibration reads it (its inverse).
std::vector<double> k_of_raw_samples(const std::vector<double>& coefficients,
                                     std::uint32_t samples);

// Fills a whole group's payload [bscan][record][sample].
void fill_group(const shm::RingGeometry& geometry, SpectrumSynthesizer& synthesizer,
                const ReflectorsOf& reflectors, std::span<std::uint16_t> payload);

// Marker of B-scan `bscan_in_volume` of volume `volume`: flags start/end at the volume's ends,
// reversed when `bidirectional` and the B-scan index is odd.
shm::BscanMarker marker_for(std::uint64_t volume, std::uint32_t bscan_in_volume,
                            std::uint32_t bscans_per_volume, bool bidirectional);

}  // namespace ioct::gpu::testing
