// One spectrum as the ADC delivers it, synthesised from a depth profile by an inverse FFT.
//
// The sample model fills the DepthProfile (complex reflectivity on a depth grid, speckle
// included); synthesize() turns it into the record:
//     C(m) = sum_p h[p] exp(+i 2 pi m p / M)                     (FFTW, M-point inverse FFT)
//     s_i  = offset + g (B_i + Re(E_i C(m_i))) + sigma_i n_i      (ADC counts, rounded, clipped)
// with m_i the sample's position on the k-linear grid, E_i = fringe counts x envelope x
// exp(i phi_dispersion), B_i the light-dependent background, g the sweep's power (RIN) and n_i
// table noise. The grid has M / N points per depth px (M the smallest power of two >= 1.4 N), so
// that a grid point at p lands at depth p N / M px: the first N outputs of the M-point transform
// are the k-linear samples.
//
// Samples off the k-linear grid (the digitizer's internal clock, or a k-clock dropout, when the
// record falls back to time-linear sampling) are read from a 2M-point transform (C at half-sample
// spacing) by a 6-tap Kaiser-Bessel interpolation whose roll-off is divided out of the profile in
// advance (a type-2 non-uniform FFT; error below 1e-4 of the fringe).
//
// Everything is built in the constructor; synthesize() neither allocates nor locks.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "ioct/hal/digitizer_config.hpp"
#include "ioct/sim/depth_profile.hpp"
#include "ioct/sim/detector.hpp"
#include "ioct/sim/interferometer.hpp"
#include "ioct/sim/spectral_sampling.hpp"
#include "ioct/sim/swept_source.hpp"

namespace ioct::sim {

struct SynthesisSetup {
  SweptSourceConfig source;
  InterferometerConfig interferometer;
  DetectorConfig detector;
  hal::ClockSource clock = hal::ClockSource::external_k_clock;
  std::uint32_t samples = 1376;
  std::uint32_t sample_bits = 12;
  std::uint64_t seed = 1;  // noise and speckle tables
};

// How one sweep was sampled.
enum class SweepSampling {
  configured,   // as the digitizer's clock source says
  time_linear,  // the k-clock dropped out: the record falls back to linear-in-time sampling
};

// The random parts of one sweep: two offsets into the noise table and the sweep's power.
struct SweepNoise {
  std::uint32_t offset_a = 0;
  std::uint32_t offset_b = 0;
  float power_gain = 1.0f;
};

class SpectrumSynthesizer {
 public:
  static constexpr std::uint32_t kNoiseOffsets = 1u << 16;
  static constexpr std::uint32_t kMaxSamples = 8192;

  // Throws std::invalid_argument for an odd sample count or more than kMaxSamples.
  explicit SpectrumSynthesizer(const SynthesisSetup& setup);
  ~SpectrumSynthesizer();
  SpectrumSynthesizer(const SpectrumSynthesizer&) = delete;
  SpectrumSynthesizer& operator=(const SpectrumSynthesizer&) = delete;

  std::uint32_t samples() const noexcept { return samples_; }
  std::uint32_t depth_bins() const noexcept { return samples_ / 2; }
  std::uint32_t fft_points() const noexcept { return fft_points_; }
  const SpectralSampling& sampling() const noexcept { return configured_.sampling; }

  // Selects the sampling of the sweeps to come (and the profile gain that goes with it). Call
  // before drawing a sweep's profile.
  void select(SweepSampling sampling) noexcept;
  // The profile of the next sweep.
  DepthProfile& profile() noexcept { return *profile_; }
  const DepthProfile& profile() const noexcept { return *profile_; }
  // A sweep's random parts from one 64-bit random word.
  SweepNoise sweep_noise(std::uint64_t random_word) const noexcept;

  // Writes samples() words to `out` from the profile drawn since the last call, and clears it.
  // With light == false (emission off) the record holds only the ADC offset and read noise.
  void synthesize(const SweepNoise& noise, bool light, std::uint16_t* out) noexcept;

 private:
  // Per-sample rows of one sampling.
  struct SampledRows {
    SpectralSampling sampling;
    std::vector<float> fringe_re;   // fringe counts x envelope x cos(phi)
    std::vector<float> fringe_im;   // ... x sin(phi)
    std::vector<float> background;  // light-dependent background
    std::vector<float> sigma;       // noise standard deviation
    bool dispersive = false;
    bool uniform = true;                   // on the k-linear grid: the direct M-point path
    std::vector<std::uint32_t> tap_first;  // first tap per sample, into the prefixed output
    std::vector<float> tap_weight;         // kTaps per sample
  };
  static constexpr std::uint32_t kTaps = 6;
  static constexpr std::uint32_t kWidePrefix = 4;  // complex values before the 2M-point output

  void release_fftw() noexcept;
  void build_tables(const SynthesisSetup& setup);
  void build_rows(SampledRows& rows, const SynthesisSetup& setup, hal::ClockSource clock);
  void write_output(const SampledRows& rows, const float* spectrum, const SweepNoise& noise,
                    bool light, std::uint16_t* out) noexcept;

  std::uint32_t samples_;
  std::uint32_t fft_points_;  // M
  float offset_ = 0.0f;
  float dark_sigma_ = 0.0f;
  float jitter_ = 0.0f;
  float max_value_ = 0.0f;
  float* profile_values_ = nullptr;  // 2M complex, FFTW-aligned
  float* direct_out_ = nullptr;      // M complex
  float* wide_out_ = nullptr;        // kWidePrefix + 2M complex
  void* direct_plan_ = nullptr;      // fftwf_plan
  void* wide_plan_ = nullptr;
  std::unique_ptr<DepthProfile> profile_;
  std::vector<float> direct_gain_;  // roll-off per grid point
  std::vector<float> wide_gain_;    // roll-off / interpolation kernel transform
  SampledRows configured_;
  SampledRows time_linear_;
  const SampledRows* active_ = nullptr;
  std::vector<float> noise_;      // standard normal / sqrt(2), kNoiseOffsets + N values
  std::vector<float> resampled_;  // N complex: the 2M-point output read at the sample positions
};

}  // namespace ioct::sim
