// Background (DC and fixed-pattern) removal: a rolling mean spectrum, per sample index, is
// subtracted from every spectrum. What is left is the interference fringe.
//
// The mean is taken over every active A-scan of the last `groups` groups, the current one
// included (4 groups of 16 x 512 A-scans, 344 ms of acquisition, by default). Fringes of moving,
// speckled tissue have random phase from A-scan to A-scan and average out of it; the source
// spectrum, the reference-arm DC and stationary reflections in the optics (the fixed pattern)
// do not, and are removed. More groups leave less of the tissue's fringes in the estimate (the
// residue falls as 1 / sqrt(A-scans averaged)); fewer follow a drifting source faster. One group
// is the plain group mean.
//
// The sums are integers (u32 per B-scan, u64 per group) and the mean is one double division per
// sample, so the CPU and CUDA implementations compute bit-identical backgrounds.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "ioct/gpu/processing/host_device.hpp"

namespace ioct::gpu {

enum class BackgroundMode {
  rolling,  // subtract the mean spectrum of the last `groups` groups
  none,     // subtract nothing (for test data that has no background)
};

std::string_view to_string(BackgroundMode mode) noexcept;
// Throws ConfigError("background", ...) naming the accepted values.
BackgroundMode parse_background_mode(std::string_view text);

struct BackgroundConfig {
  BackgroundMode mode = BackgroundMode::rolling;
  std::uint32_t groups = 4;  // groups in the rolling mean, the current one included
  // Throws ConfigError: mode, background_groups in [1, 64].
  void validate() const;
};

// The history of group sums behind a rolling mean: the last `groups` groups' per-sample sums and
// A-scan counts. Shared arithmetic of the CPU estimator and (for its counts) the CUDA one.
class RollingSums {
 public:
  void reset(std::uint32_t groups, std::uint32_t samples);
  // The slot the next group's sums go into, and its A-scan count; advances the history.
  std::uint32_t push(std::uint64_t ascans) noexcept;
  // A-scans summed over the history (the groups pushed so far, at most `groups`).
  std::uint64_t total_ascans() const noexcept { return total_ascans_; }
  std::uint32_t slots() const noexcept { return static_cast<std::uint32_t>(counts_.size()); }
  std::uint32_t used_slots() const noexcept { return used_; }
  std::span<std::uint64_t> sums(std::uint32_t slot) noexcept {
    return {sums_.data() + std::size_t{slot} * samples_, samples_};
  }
  std::span<const std::uint64_t> sums(std::uint32_t slot) const noexcept {
    return {sums_.data() + std::size_t{slot} * samples_, samples_};
  }

 private:
  std::uint32_t samples_ = 0;
  std::uint32_t next_ = 0;
  std::uint32_t used_ = 0;
  std::uint64_t total_ascans_ = 0;
  std::vector<std::uint64_t> counts_;  // [slot]
  std::vector<std::uint64_t> sums_;    // [slot][sample]
};

// The mean of `total` over `count` A-scans as both implementations round it.
IOCT_HD float background_mean(std::uint64_t total, std::uint64_t count) noexcept {
  return static_cast<float>(static_cast<double>(total) / static_cast<double>(count));
}

// The CPU estimate of the rolling mean spectrum. accumulate_bscan() for different B-scans may
// run on different threads at once; finish() runs after all of them, once per group.
class CpuBackgroundEstimator {
 public:
  // Throws std::invalid_argument when a B-scan has more than 65536 records (the per-B-scan sums
  // are 32-bit: 65536 x 65535 still fits). Forgets the history.
  void prepare(const BackgroundConfig& config, std::uint32_t samples_per_ascan,
               std::uint32_t max_bscans, std::uint32_t max_records_per_bscan);

  // Sums `record_count` spectra of `samples_per_ascan` samples starting at `records` into the
  // partial sums of B-scan `bscan`.
  void accumulate_bscan(std::uint32_t bscan, const std::uint16_t* records,
                        std::uint32_t record_count) noexcept;

  // Adds the partial sums of B-scans [0, bscan_count) to the history as one group and updates
  // the mean spectrum.
  void finish(std::uint32_t bscan_count, std::uint32_t records_per_bscan) noexcept;

  // The spectrum to subtract: the rolling mean, or zeros when the mode is none.
  std::span<const float> background() const noexcept { return background_; }
  BackgroundMode mode() const noexcept { return mode_; }

 private:
  BackgroundMode mode_ = BackgroundMode::rolling;
  std::uint32_t samples_ = 0;
  std::vector<std::uint32_t> partial_sums_;  // [bscan][sample]
  RollingSums history_;
  std::vector<float> background_;
};

}  // namespace ioct::gpu
