#include "ioct/gpu/processing/fftw_r2c_plan.hpp"

#include <fftw3.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "fftw_planner.hpp"
#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

static_assert(sizeof(std::complex<float>) == sizeof(fftwf_complex),
              "std::complex<float> and fftwf_complex share one layout");

std::mutex& planner_mutex() {
  static std::mutex mutex;
  return mutex;
}

unsigned planner_flags(FftRigor rigor) {
  switch (rigor) {
    case FftRigor::estimate:
      return FFTW_ESTIMATE;
    case FftRigor::measure:
      return FFTW_MEASURE;
    case FftRigor::patient:
      return FFTW_PATIENT;
  }
  return FFTW_MEASURE;
}

void import_wisdom(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return;  // first run: nothing to import yet
  if (fftwf_import_wisdom_from_filename(path.c_str()) == 0) {
    throw ConfigError("fft_wisdom", "'" + path + "'", "is not a readable FFTW wisdom file");
  }
}

void export_wisdom(const std::string& path) {
  // Into a temporary file and then renamed, so a crash never leaves half a wisdom file.
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  if (fftwf_export_wisdom_to_filename(temporary.c_str()) == 0 ||
      std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw ConfigError("fft_wisdom", "'" + path + "'", "could not be written");
  }
}

std::string_view to_string(FftRigor rigor) noexcept {
  switch (rigor) {
    case FftRigor::estimate:
      return "estimate";
    case FftRigor::measure:
      return "measure";
    case FftRigor::patient:
      return "patient";
  }
  return "?";
}

FftRigor parse_fft_rigor(std::string_view text) {
  if (text == "estimate") return FftRigor::estimate;
  if (text == "measure") return FftRigor::measure;
  if (text == "patient") return FftRigor::patient;
  throw ConfigError("fft_rigor", "'" + std::string(text) + "'",
                    "must be estimate, measure or patient");
}

void FftConfig::validate() const {
  if (rigor != FftRigor::estimate && rigor != FftRigor::measure && rigor != FftRigor::patient) {
    throw ConfigError("fft_rigor", std::to_string(static_cast<int>(rigor)),
                      "must be estimate, measure or patient");
  }
  std::error_code ec;
  if (!wisdom_path.empty() && std::filesystem::is_directory(wisdom_path, ec)) {
    throw ConfigError("fft_wisdom", "'" + wisdom_path + "'", "is a directory, not a file");
  }
}

template <class T>
FftwArray<T>::FftwArray(std::size_t count)
    : data_(static_cast<T*>(fftwf_malloc(count * sizeof(T)))), count_(count) {
  if (data_ == nullptr && count != 0) throw std::bad_alloc();
  for (std::size_t i = 0; i < count; ++i) data_[i] = T{};
}

template <class T>
FftwArray<T>& FftwArray<T>::operator=(FftwArray&& other) noexcept {
  if (this != &other) {
    fftwf_free(data_);
    data_ = std::exchange(other.data_, nullptr);
    count_ = std::exchange(other.count_, 0);
  }
  return *this;
}

template <class T>
FftwArray<T>::~FftwArray() {
  fftwf_free(data_);
}

template class FftwArray<float>;
template class FftwArray<std::complex<float>>;

FftwR2cPlan::FftwR2cPlan(const FftConfig& config, std::uint32_t samples, std::uint32_t howmany,
                         std::uint32_t in_distance, std::uint32_t out_distance, float* in,
                         std::complex<float>* out) {
  config.validate();
  if (samples < 2 || howmany < 1 || in_distance < samples || out_distance < samples / 2 + 1) {
    throw std::invalid_argument("FFT plan: samples " + std::to_string(samples) + ", howmany " +
                                std::to_string(howmany) + ", distances " +
                                std::to_string(in_distance) + "/" + std::to_string(out_distance) +
                                " do not describe a batch of transforms");
  }
  std::lock_guard lock(planner_mutex());
  if (!config.wisdom_path.empty()) import_wisdom(config.wisdom_path);
  const int n[1] = {static_cast<int>(samples)};
  plan_ = fftwf_plan_many_dft_r2c(1, n, static_cast<int>(howmany), in, nullptr, 1,
                                  static_cast<int>(in_distance),
                                  reinterpret_cast<fftwf_complex*>(out), nullptr, 1,
                                  static_cast<int>(out_distance), planner_flags(config.rigor));
  if (plan_ == nullptr) {
    throw std::runtime_error("FFTW returned no plan for " + std::to_string(howmany) + " x " +
                             std::to_string(samples) + " real-to-complex transforms");
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

FftwR2cPlan::FftwR2cPlan(FftwR2cPlan&& other) noexcept
    : plan_(std::exchange(other.plan_, nullptr)) {}

FftwR2cPlan& FftwR2cPlan::operator=(FftwR2cPlan&& other) noexcept {
  if (this != &other) {
    if (plan_ != nullptr) {
      std::lock_guard lock(planner_mutex());
      fftwf_destroy_plan(plan_);
    }
    plan_ = std::exchange(other.plan_, nullptr);
  }
  return *this;
}

FftwR2cPlan::~FftwR2cPlan() {
  if (plan_ == nullptr) return;
  std::lock_guard lock(planner_mutex());
  fftwf_destroy_plan(plan_);
}

void FftwR2cPlan::execute(float* in, std::complex<float>* out) const noexcept {
  fftwf_execute_dft_r2c(plan_, in, reinterpret_cast<fftwf_complex*>(out));
}

}  // namespace ioct::gpu
