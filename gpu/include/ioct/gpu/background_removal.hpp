// Background (DC and fixed-pattern) removal: the mean spectrum of a group, per sample index, is
// subtracted from every spectrum of that group. What is left is the interference fringe.
//
// The mean is taken over the active A-scans of all B-scans in the group (16 x 512 spectra by
// default). Fringes of moving, speckled tissue average out over that many A-scans; the source
// spectrum, the reference-arm DC and stationary reflections in the optics do not, and are removed.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace ioct::gpu {

enum class BackgroundMode {
  group_mean,  // subtract the mean spectrum of the group being processed
  none,        // subtract nothing (for test data that has no background)
};

std::string_view to_string(BackgroundMode mode) noexcept;
// Throws ConfigError("background", ...) naming the accepted values.
BackgroundMode parse_background_mode(std::string_view text);

struct BackgroundConfig {
  BackgroundMode mode = BackgroundMode::group_mean;
  void validate() const;
};

// The CPU estimate of the group's mean spectrum. accumulate_bscan() for different B-scans may run
// on different threads at once; finish() runs after all of them.
class CpuBackgroundEstimator {
 public:
  // Throws std::invalid_argument when a B-scan has more than 65536 records (the per-B-scan sums
  // are 32-bit: 65536 x 65535 still fits).
  void prepare(const BackgroundConfig& config, std::uint32_t samples_per_ascan,
               std::uint32_t max_bscans, std::uint32_t max_records_per_bscan);

  // Sums `record_count` spectra of `samples_per_ascan` samples starting at `records` into the
  // partial sums of B-scan `bscan`.
  void accumulate_bscan(std::uint32_t bscan, const std::uint16_t* records,
                        std::uint32_t record_count) noexcept;

  // Turns the partial sums of B-scans [0, bscan_count) into the mean spectrum.
  void finish(std::uint32_t bscan_count, std::uint32_t records_per_bscan) noexcept;

  // The spectrum to subtract: the mean, or zeros when the mode is none.
  std::span<const float> background() const noexcept { return background_; }
  BackgroundMode mode() const noexcept { return mode_; }

 private:
  BackgroundMode mode_ = BackgroundMode::group_mean;
  std::uint32_t samples_ = 0;
  std::vector<std::uint32_t> partial_sums_;  // [bscan][sample]
  std::vector<float> background_;
};

}  // namespace ioct::gpu
