#include "ioct/gpu/processing/background_removal.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

std::string_view to_string(BackgroundMode mode) noexcept {
  switch (mode) {
    case BackgroundMode::rolling:
      return "rolling";
    case BackgroundMode::none:
      return "none";
  }
  return "?";
}

BackgroundMode parse_background_mode(std::string_view text) {
  if (text == "rolling") return BackgroundMode::rolling;
  if (text == "none") return BackgroundMode::none;
  throw ConfigError("background", "'" + std::string(text) + "'", "must be rolling or none");
}

void BackgroundConfig::validate() const {
  if (mode != BackgroundMode::rolling && mode != BackgroundMode::none) {
    throw ConfigError("background", std::to_string(static_cast<int>(mode)),
                      "must be rolling or none");
  }
  require_integer_in_range("background_groups", groups, 1, 64);
}

void RollingSums::reset(std::uint32_t groups, std::uint32_t samples) {
  samples_ = samples;
  next_ = 0;
  used_ = 0;
  total_ascans_ = 0;
  counts_.assign(groups, 0);
  sums_.assign(std::size_t{groups} * samples, 0);
}

std::uint32_t RollingSums::push(std::uint64_t ascans) noexcept {
  const std::uint32_t slot = next_;
  total_ascans_ = total_ascans_ - counts_[slot] + ascans;
  counts_[slot] = ascans;
  next_ = (next_ + 1) % slots();
  used_ = std::min(used_ + 1, slots());
  return slot;
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
  history_.reset(config.mode == BackgroundMode::none ? 1 : config.groups, samples_per_ascan);
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
  const std::uint32_t slot = history_.push(std::uint64_t{records_per_bscan} * bscan_count);
  const std::span<std::uint64_t> group = history_.sums(slot);
  for (std::uint32_t s = 0; s < samples_; ++s) {
    std::uint64_t total = 0;
    for (std::uint32_t b = 0; b < bscan_count; ++b) {
      total += partial_sums_[std::size_t{b} * samples_ + s];
    }
    group[s] = total;
  }
  const std::uint64_t count = history_.total_ascans();
  for (std::uint32_t s = 0; s < samples_; ++s) {
    std::uint64_t total = 0;
    for (std::uint32_t h = 0; h < history_.used_slots(); ++h) total += history_.sums(h)[s];
    background_[s] = background_mean(total, count);
  }
}

}  // namespace ioct::gpu
