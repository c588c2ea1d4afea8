// The FFT stage on the CPU: a batch of real-to-complex transforms planned once by FFTW.
//
// FFTW's planner is not thread-safe, so planning, wisdom and plan destruction go through one
// process-wide mutex here. Executing a plan is thread-safe; each thread passes its own buffers
// (new-array execution), which must be allocated with FftwArray so their alignment matches.
#pragma once

#include <complex>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

struct fftwf_plan_s;

namespace ioct::gpu {

enum class FftRigor {
  estimate,  // no measuring: instant, slower transforms (tests)
  measure,   // times candidate algorithms at start-up (about a second for the default geometry)
  patient,   // times many more; worth it together with a wisdom file
};

std::string_view to_string(FftRigor rigor) noexcept;
// Throws ConfigError("fft_rigor", ...) naming the accepted values.
FftRigor parse_fft_rigor(std::string_view text);

struct FftConfig {
  FftRigor rigor = FftRigor::measure;
  // When set, wisdom is read from this file before planning (a missing file is fine) and the
  // updated wisdom is written back after, so a patient plan is paid for once.
  std::string wisdom_path;
  void validate() const;
};

// Memory from fftwf_malloc: aligned for FFTW's SIMD code. Move-only.
template <class T>
class FftwArray {
 public:
  FftwArray() = default;
  explicit FftwArray(std::size_t count);
  FftwArray(FftwArray&& other) noexcept : data_(other.data_), count_(other.count_) {
    other.data_ = nullptr;
    other.count_ = 0;
  }
  FftwArray& operator=(FftwArray&& other) noexcept;
  FftwArray(const FftwArray&) = delete;
  FftwArray& operator=(const FftwArray&) = delete;
  ~FftwArray();

  T* data() const noexcept { return data_; }
  std::size_t size() const noexcept { return count_; }

 private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
};

extern template class FftwArray<float>;
extern template class FftwArray<std::complex<float>>;

class FftwR2cPlan {
 public:
  FftwR2cPlan() = default;
  // `howmany` transforms of `samples` reals; input rows `in_distance` floats apart, output rows
  // (samples / 2 + 1 bins) `out_distance` complex values apart. `in` and `out` are used (and
  // overwritten) while measuring. Throws std::runtime_error when FFTW returns no plan and
  // ConfigError for an unreadable wisdom file.
  FftwR2cPlan(const FftConfig& config, std::uint32_t samples, std::uint32_t howmany,
              std::uint32_t in_distance, std::uint32_t out_distance, float* in,
              std::complex<float>* out);
  FftwR2cPlan(FftwR2cPlan&& other) noexcept;
  FftwR2cPlan& operator=(FftwR2cPlan&& other) noexcept;
  FftwR2cPlan(const FftwR2cPlan&) = delete;
  FftwR2cPlan& operator=(const FftwR2cPlan&) = delete;
  ~FftwR2cPlan();

  // Runs the plan on other buffers of the same shape, allocated by FftwArray. Thread-safe.
  void execute(float* in, std::complex<float>* out) const noexcept;
  bool valid() const noexcept { return plan_ != nullptr; }

 private:
  fftwf_plan_s* plan_ = nullptr;
};

}  // namespace ioct::gpu
