#include "ioct/sim/spectrum_synthesizer.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>

#include "ioct/sim/random.hpp"

namespace ioct::sim {
namespace {

// FFTW's planner is not thread-safe; execution is.
std::mutex& planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

constexpr std::uint64_t kNoiseTableStream = 0x6E6F6973'65746162;  // "noisetab"
constexpr std::uint64_t kTextureStream = 0x74657874'75726521;     // "texture!"

// Kaiser-Bessel interpolation kernel of width 6 (half-sample grid, oversampling 2).
constexpr double kKernelHalfWidth = 3.0;
constexpr double kKernelBeta = 13.855;  // pi sqrt((W/s)^2 (s - 1/2)^2 - 0.8), W = 6, s = 2

double kernel(double t) noexcept {
  const double r = t / kKernelHalfWidth;
  if (std::abs(r) >= 1.0) return 0.0;
  return std::cyl_bessel_i(0.0, kKernelBeta * std::sqrt(1.0 - r * r));
}

// Continuous Fourier transform of the kernel at `frequency` (cycles per half-sample), in
// closed form: 2h sinh(sqrt(b^2 - (2 pi h f)^2)) / sqrt(b^2 - (2 pi h f)^2), h = W/2.
double kernel_transform(double frequency) noexcept {
  const double w = 2.0 * std::numbers::pi * kKernelHalfWidth * frequency;
  const double s2 = kKernelBeta * kKernelBeta - w * w;
  if (s2 > 1e-12) {
    const double s = std::sqrt(s2);
    return 2.0 * kKernelHalfWidth * std::sinh(s) / s;
  }
  if (s2 < -1e-12) {
    const double s = std::sqrt(-s2);
    return 2.0 * kKernelHalfWidth * std::sin(s) / s;
  }
  return 2.0 * kKernelHalfWidth;
}

std::uint32_t fft_size_for(std::uint32_t samples) {
  std::uint32_t m = 64;
  while (static_cast<double>(m) < 1.4 * samples) m *= 2;
  return m;
}

}  // namespace

SpectrumSynthesizer::SpectrumSynthesizer(const SynthesisSetup& setup)
    : samples_(setup.samples), fft_points_(fft_size_for(setup.samples)) {
  if (samples_ < 16 || samples_ % 2 != 0 || samples_ > kMaxSamples) {
    throw std::invalid_argument("spectrum synthesizer: " + std::to_string(samples_) +
                                " samples; need an even count in [16, " +
                                std::to_string(kMaxSamples) + "]");
  }
  const std::size_t m = fft_points_;
  profile_values_ = fftwf_alloc_real(4 * m);
  direct_out_ = fftwf_alloc_real(2 * m);
  wide_out_ = fftwf_alloc_real(4 * m + 2 * kWidePrefix);
  if (profile_values_ == nullptr || direct_out_ == nullptr || wide_out_ == nullptr) {
    fftwf_free(profile_values_);
    fftwf_free(direct_out_);
    fftwf_free(wide_out_);
    throw std::bad_alloc();
  }
  std::fill(profile_values_, profile_values_ + 4 * m, 0.0f);
  {
    const std::lock_guard<std::mutex> lock(planner_mutex());
    // FFTW_ESTIMATE: the plan does not depend on timing, so the same build gives the same
    // bytes; the input is kept (the profile is cleared only where it was written).
    auto* in = reinterpret_cast<fftwf_complex*>(profile_values_);
    direct_plan_ =
        fftwf_plan_dft_1d(static_cast<int>(m), in, reinterpret_cast<fftwf_complex*>(direct_out_),
                          FFTW_BACKWARD, FFTW_ESTIMATE | FFTW_PRESERVE_INPUT);
    wide_plan_ = fftwf_plan_dft_1d(static_cast<int>(2 * m), in,
                                   reinterpret_cast<fftwf_complex*>(wide_out_ + 2 * kWidePrefix),
                                   FFTW_BACKWARD, FFTW_ESTIMATE | FFTW_PRESERVE_INPUT);
  }
  if (direct_plan_ == nullptr || wide_plan_ == nullptr) {
    release_fftw();
    throw std::runtime_error("spectrum synthesizer: FFTW could not plan the transforms");
  }

  try {
    build_tables(setup);
  } catch (...) {
    release_fftw();
    throw;
  }
}

void SpectrumSynthesizer::build_tables(const SynthesisSetup& setup) {
  const std::size_t m = fft_points_;
  const double grid_per_px = static_cast<double>(m) / samples_;
  const std::uint32_t grid_points = fft_points_ / 2;
  profile_ = std::make_unique<DepthProfile>(profile_values_, grid_points, grid_per_px,
                                            splitmix64(setup.seed ^ kTextureStream));
  direct_gain_.resize(grid_points);
  wide_gain_.resize(grid_points);
  const double axial_mm = setup.source.axial_pixel_um() * 1e-3;
  for (std::uint32_t p = 0; p < grid_points; ++p) {
    const double rolloff = setup.source.rolloff_at_mm(p / grid_per_px * axial_mm);
    direct_gain_[p] = static_cast<float>(rolloff);
    // The 2M-point output is C at half-sample spacing: grid point p has frequency p / (2M)
    // cycles per half-sample there.
    wide_gain_[p] =
        static_cast<float>(rolloff / kernel_transform(p / (2.0 * static_cast<double>(m))));
  }

  const double scale = DetectorConfig::count_scale(setup.sample_bits);
  offset_ = static_cast<float>(scale * setup.detector.adc_offset_counts);
  dark_sigma_ = static_cast<float>(scale * setup.detector.read_noise_counts);
  jitter_ = static_cast<float>(setup.detector.sweep_power_jitter);
  max_value_ = static_cast<float>((1u << setup.sample_bits) - 1u);
  build_rows(configured_, setup, setup.clock);
  build_rows(time_linear_, setup, hal::ClockSource::internal);
  resampled_.resize(2 * std::size_t{samples_});

  noise_.resize(std::size_t{kNoiseOffsets} + samples_);
  Xoshiro256 rng(splitmix64(setup.seed ^ kNoiseTableStream));
  for (float& value : noise_) value = static_cast<float>(rng.normal() * std::sqrt(0.5));
  select(SweepSampling::configured);
}

SpectrumSynthesizer::~SpectrumSynthesizer() {
  release_fftw();
}

void SpectrumSynthesizer::release_fftw() noexcept {
  {
    const std::lock_guard<std::mutex> lock(planner_mutex());
    if (direct_plan_ != nullptr) fftwf_destroy_plan(static_cast<fftwf_plan>(direct_plan_));
    if (wide_plan_ != nullptr) fftwf_destroy_plan(static_cast<fftwf_plan>(wide_plan_));
    direct_plan_ = nullptr;
    wide_plan_ = nullptr;
  }
  fftwf_free(profile_values_);
  fftwf_free(direct_out_);
  fftwf_free(wide_out_);
  profile_values_ = direct_out_ = wide_out_ = nullptr;
}

void SpectrumSynthesizer::build_rows(SampledRows& rows, const SynthesisSetup& setup,
                                     hal::ClockSource clock) {
  rows.sampling = spectral_sampling(setup.source, clock, samples_);
  rows.uniform = rows.sampling.k_linear;
  rows.dispersive = setup.interferometer.dispersive();
  const double scale = DetectorConfig::count_scale(setup.sample_bits);
  const double fringe = scale * setup.detector.fringe_counts;
  std::vector<float> envelope(samples_);
  rows.fringe_re.resize(samples_);
  rows.fringe_im.resize(samples_);
  const double k_step = (setup.source.k_max() - setup.source.k_min()) / samples_;
  for (std::uint32_t i = 0; i < samples_; ++i) {
    const double k_index = rows.sampling.k_index[i];
    const double power = setup.source.power_at_k(setup.source.k_min() + k_index * k_step);
    envelope[i] = static_cast<float>(power);
    const double phase = setup.interferometer.dispersion_phase(k_index, samples_);
    rows.fringe_re[i] = static_cast<float>(fringe * power * std::cos(phase));
    rows.fringe_im[i] = static_cast<float>(fringe * power * std::sin(phase));
  }
  rows.background =
      setup.detector.light_background(envelope, rows.sampling.k_index, setup.sample_bits);
  rows.sigma = setup.detector.noise_sigma(envelope, setup.sample_bits);
  if (rows.uniform) return;
  rows.tap_first.resize(samples_);
  rows.tap_weight.resize(std::size_t{samples_} * kTaps);
  for (std::uint32_t i = 0; i < samples_; ++i) {
    const double u = 2.0 * rows.sampling.k_index[i];  // position in half-samples
    const auto base = static_cast<std::int64_t>(std::floor(u)) - 2;
    // Taps base .. base + 5; the first samples reach a little before index 0, which the wide
    // output's prefix holds (the transform is periodic).
    rows.tap_first[i] = static_cast<std::uint32_t>(base + kWidePrefix);
    for (std::uint32_t t = 0; t < kTaps; ++t) {
      rows.tap_weight[std::size_t{i} * kTaps + t] =
          static_cast<float>(kernel(u - static_cast<double>(base + t)));
    }
  }
}

void SpectrumSynthesizer::select(SweepSampling sampling) noexcept {
  active_ = sampling == SweepSampling::time_linear ? &time_linear_ : &configured_;
  profile_->set_gain(active_->uniform ? direct_gain_ : wide_gain_);
}

SweepNoise SpectrumSynthesizer::sweep_noise(std::uint64_t random_word) const noexcept {
  SweepNoise noise;
  noise.offset_a = static_cast<std::uint32_t>(random_word & 0xFFFF);
  noise.offset_b = static_cast<std::uint32_t>((random_word >> 16) & 0xFFFF);
  const float normal = noise_[(random_word >> 32) & 0xFFFF] * std::numbers::sqrt2_v<float>;
  noise.power_gain = 1.0f + jitter_ * normal;
  return noise;
}

void SpectrumSynthesizer::synthesize(const SweepNoise& noise, bool light,
                                     std::uint16_t* out) noexcept {
  const SampledRows& rows = *active_;
  const float* spectrum = nullptr;
  if (light && !profile_->empty()) {
    if (rows.uniform) {
      fftwf_execute(static_cast<fftwf_plan>(direct_plan_));
      spectrum = direct_out_;
    } else {
      fftwf_execute(static_cast<fftwf_plan>(wide_plan_));
      // The prefix repeats the transform's last values (it is periodic).
      const std::size_t wide_points = 2 * std::size_t{fft_points_};
      float* __restrict wide = wide_out_;
      for (std::size_t k = 0; k < 2 * kWidePrefix; ++k) {
        wide[k] = wide[2 * wide_points + k];
      }
      const std::uint32_t* __restrict first = rows.tap_first.data();
      const float* __restrict weight = rows.tap_weight.data();
      float* __restrict resampled = resampled_.data();
      for (std::uint32_t i = 0; i < samples_; ++i) {
        const float* __restrict c = wide + 2 * std::size_t{first[i]};
        const float* __restrict w = weight + std::size_t{i} * kTaps;
        resampled[2 * i] =
            w[0] * c[0] + w[1] * c[2] + w[2] * c[4] + w[3] * c[6] + w[4] * c[8] + w[5] * c[10];
        resampled[2 * i + 1] =
            w[0] * c[1] + w[1] * c[3] + w[2] * c[5] + w[3] * c[7] + w[4] * c[9] + w[5] * c[11];
      }
      spectrum = resampled_.data();
    }
  }
  profile_->clear();
  write_output(rows, spectrum, noise, light, out);
}

void SpectrumSynthesizer::write_output(const SampledRows& rows, const float* spectrum,
                                       const SweepNoise& noise, bool light,
                                       std::uint16_t* __restrict out) noexcept {
  const std::size_t n = samples_;
  const float* __restrict noise_a = noise_.data() + noise.offset_a;
  const float* __restrict noise_b = noise_.data() + noise.offset_b;
  const float offset = offset_;
  const float top = max_value_;
  const auto quantise = [top](float value) {
    const float clipped = std::min(std::max(value, 0.0f), top);
    return static_cast<std::uint16_t>(static_cast<std::int32_t>(clipped + 0.5f));
  };
  if (!light) {
    const float sigma = dark_sigma_;
    for (std::size_t i = 0; i < n; ++i)
      out[i] = quantise(offset + sigma * (noise_a[i] + noise_b[i]));
    return;
  }
  const float gain = noise.power_gain;
  const float* __restrict background = rows.background.data();
  const float* __restrict sigma = rows.sigma.data();
  if (spectrum == nullptr) {
    for (std::size_t i = 0; i < n; ++i) {
      out[i] = quantise(offset + gain * background[i] + sigma[i] * (noise_a[i] + noise_b[i]));
    }
    return;
  }
  const float* __restrict c = spectrum;
  const float* __restrict fringe_re = rows.fringe_re.data();
  if (rows.dispersive) {
    const float* __restrict fringe_im = rows.fringe_im.data();
    for (std::size_t i = 0; i < n; ++i) {
      const float fringe = fringe_re[i] * c[2 * i] - fringe_im[i] * c[2 * i + 1];
      out[i] =
          quantise(offset + gain * (background[i] + fringe) + sigma[i] * (noise_a[i] + noise_b[i]));
    }
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const float fringe = fringe_re[i] * c[2 * i];
    out[i] =
        quantise(offset + gain * (background[i] + fringe) + sigma[i] * (noise_a[i] + noise_b[i]));
  }
}

}  // namespace ioct::sim
