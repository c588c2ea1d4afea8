#include "ioct/gpu/background_removal.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

std::string_view to_string(BackgroundMode mode) noexcept {
  switch (mode) {
    case BackgroundMode::group_mean:
      return "group-mean";
    case BackgroundMode::none:
      return "none";
  }
  return "?";
}

BackgroundMode parse_background_mode(std::string_view text) {
  if (text == "group-mean") return BackgroundMode::group_mean;
  if (text == "none") return BackgroundMode::none;
  throw ConfigError("background", "'" + std::string(text) + "'", "must be group-mean or none");
}

void BackgroundConfig::validate() const {
  if (mode != BackgroundMode::group_mean && mode != BackgroundMode::none) {
    throw ConfigError("background", std::to_string(static_cast<int>(mode)),
                      "must be group-mean or none");
  }
}

void CpuBackgroundEstimator::prepare(const BackgroundConfig& config,
                                     std::uint32_t samples_per_ascan, std::uint32_t max_bscans,
                                     std::uint32_t max_records_per_bscan) {
  config.validate();
  if (max_records_per_bscan > 65536) {
    throw std::invalid_argument("background removal: " + std::to_string(max_records_per_bscan) +
                                " A-scans per B-scan, at most 65536 are supported");
  }
  mode_ = config.mode;
  samples_ = samples_per_ascan;
  partial_sums_.assign(std::size_t{max_bscans} * samples_per_ascan, 0);
  background_.assign(samples_per_ascan, 0.0f);
}

void CpuBackgroundEstimator::accumulate_bscan(std::uint32_t bscan, const std::uint16_t* records,
                                              std::uint32_t record_count) noexcept {
  if (mode_ == BackgroundMode::none) return;
  const std::uint32_t samples = samples_;  // a local: the u32 stores below could alias a member
  std::uint32_t* __restrict sums = partial_sums_.data() + std::size_t{bscan} * samples;
  std::fill(sums, sums + samples, 0u);
  for (std::uint32_t r = 0; r < record_count; ++r) {
    const std::uint16_t* __restrict spectrum = records + std::size_t{r} * samples;
    for (std::uint32_t s = 0; s < samples; ++s) sums[s] += spectrum[s];
  }
}

void CpuBackgroundEstimator::finish(std::uint32_t bscan_count,
                                    std::uint32_t records_per_bscan) noexcept {
  if (mode_ == BackgroundMode::none) return;
  const double scale = 1.0 / (static_cast<double>(records_per_bscan) * bscan_count);
  for (std::uint32_t s = 0; s < samples_; ++s) {
    std::uint64_t total = 0;
    for (std::uint32_t b = 0; b < bscan_count; ++b) {
      total += partial_sums_[std::size_t{b} * samples_ + s];
    }
    background_[s] = static_cast<float>(static_cast<double>(total) * scale);
  }
}

}  // namespace ioct::gpu
