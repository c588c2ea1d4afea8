#include "ioct/gpu/processing/fftw_c2c_plan.hpp"

#include <fftw3.h>

#include <stdexcept>
#include <string>
#include <utility>

#include "fftw_planner.hpp"

namespace ioct::gpu {

FftwC2cPlan::FftwC2cPlan(const FftConfig& config, std::uint32_t samples, std::uint32_t howmany,
                         std::uint32_t distance, std::complex<float>* in,
                         std::complex<float>* out) {
  config.validate();
  if (samples < 2 || howmany < 1 || distance < samples) {
    throw std::invalid_argument("FFT plan: samples " + std::to_string(samples) + ", howmany " +
                                std::to_string(howmany) + ", distance " + std::to_string(distance) +
                                " do not describe a batch of transforms");
  }
  std::lock_guard lock(planner_mutex());
  if (!config.wisdom_path.empty()) import_wisdom(config.wisdom_path);
  const int n[1] = {static_cast<int>(samples)};
  plan_ = fftwf_plan_many_dft(
      1, n, static_cast<int>(howmany), reinterpret_cast<fftwf_complex*>(in), nullptr, 1,
      static_cast<int>(distance), reinterpret_cast<fftwf_complex*>(out), nullptr, 1,
      static_cast<int>(distance), FFTW_FORWARD, planner_flags(config.rigor));
  if (plan_ == nullptr) {
    throw std::runtime_error("FFTW returned no plan for " + std::to_string(howmany) + " x " +
                             std::to_string(samples) + " complex transforms");
  }
  if (!config.wisdom_path.empty()) {
    try {
      export_wisdom(config.wisdom_path);
    } catch (...) {
      fftwf_destroy_plan(std::exchange(plan_, nullptr));
      throw;
    }
  }
}

FftwC2cPlan::FftwC2cPlan(FftwC2cPlan&& other) noexcept
    : plan_(std::exchange(other.plan_, nullptr)) {}

FftwC2cPlan& FftwC2cPlan::operator=(FftwC2cPlan&& other) noexcept {
  if (this != &other) {
    if (plan_ != nullptr) {
      std::lock_guard lock(planner_mutex());
      fftwf_destroy_plan(plan_);
    }
    plan_ = std::exchange(other.plan_, nullptr);
  }
  return *this;
}

FftwC2cPlan::~FftwC2cPlan() {
  if (plan_ == nullptr) return;
  std::lock_guard lock(planner_mutex());
  fftwf_destroy_plan(plan_);
}

void FftwC2cPlan::execute(std::complex<float>* in, std::complex<float>* out) const noexcept {
  fftwf_execute_dft(plan_, reinterpret_cast<fftwf_complex*>(in),
                    reinterpret_cast<fftwf_complex*>(out));
}

}  // namespace ioct::gpu
