// The FFT stage on the CPU when the spectra are complex (dispersion compensation): a batch of
// forward complex-to-complex transforms planned once by FFTW, with the same rules as FftwR2cPlan
// (one planner mutex, new-array execution on FftwArray buffers, optional wisdom file).
#pragma once

#include <complex>
#include <cstdint>

#include "ioct/gpu/processing/fftw_r2c_plan.hpp"

struct fftwf_plan_s;

namespace ioct::gpu {

class FftwC2cPlan {
 public:
  FftwC2cPlan() = default;
  // `howmany` forward transforms of `samples` points, rows `distance` complex values apart in
  // both `in` and `out` (used and overwritten while measuring). Throws std::runtime_error when
  // FFTW returns no plan and ConfigError for an unreadable wisdom file.
  FftwC2cPlan(const FftConfig& config, std::uint32_t samples, std::uint32_t howmany,
              std::uint32_t distance, std::complex<float>* in, std::complex<float>* out);
  FftwC2cPlan(FftwC2cPlan&& other) noexcept;
  FftwC2cPlan& operator=(FftwC2cPlan&& other) noexcept;
  FftwC2cPlan(const FftwC2cPlan&) = delete;
  FftwC2cPlan& operator=(const FftwC2cPlan&) = delete;
  ~FftwC2cPlan();

  // Runs the plan on other buffers of the same shape, allocated by FftwArray. Thread-safe.
  void execute(std::complex<float>* in, std::complex<float>* out) const noexcept;
  bool valid() const noexcept { return plan_ != nullptr; }

 private:
  fftwf_plan_s* plan_ = nullptr;
};

}  // namespace ioct::gpu
