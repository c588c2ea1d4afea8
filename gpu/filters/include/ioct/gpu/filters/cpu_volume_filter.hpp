// The CPU implementation of the volume filters: the reference the CUDA one is tested against,
// and the filter of machines without a GPU.
//
// The median is the paper's forgetful selection per voxel (median_networks.hpp, algorithm 1);
// the loop over depth is written so the compiler vectorises it (one voxel per SIMD lane). The
// Gaussian is separable in fixed point (gaussian_taps.hpp). Output B-scans are spread over a
// WorkerPool, one B-scan per task.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "ioct/gpu/filters/gaussian_taps.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu::filters {

class CpuVolumeFilter final : public VolumeFilter {
 public:
  // Validates the config (ConfigError); threads >= 1, the caller included.
  explicit CpuVolumeFilter(const VolumeFilterConfig& config, unsigned threads = 1);

  void filter_volume(const Volume& in, Volume& out) override;
  using VolumeFilter::filter_group;
  BscanRange filter_group(const Volume& in, Volume& out, std::uint32_t first_bscan,
                          std::uint32_t count) override;
  const VolumeFilterConfig& config() const noexcept override { return config_; }
  std::string_view backend_name() const noexcept override { return "cpu"; }

 private:
  // Per-thread scratch: the median of one B-scan and the Gaussian's horizontal sums.
  struct Workspace {
    std::vector<std::uint8_t> median;
    std::vector<std::uint32_t> rows;
  };

  void filter_bscans(const Volume& in, Volume& out, BscanRange outputs);
  void filter_bscan(const Volume& in, Volume& out, std::uint32_t bscan, Workspace& workspace) const;

  VolumeFilterConfig config_;
  GaussianTaps taps_;
  WorkerPool pool_;
  std::vector<Workspace> workspaces_;
};

// The single steps on one B-scan, for tests and for other CPU stages.
// Median of output B-scan `bscan` of `in` (clamped borders) into `out` (ascans x depth).
void median3x3x3_bscan(const Volume& in, std::uint32_t bscan, std::span<std::uint8_t> out);
// The same with the 3x3 window inside the B-scan (A-scans x depth; the second paper's).
void median3x3_bscan(const Volume& in, std::uint32_t bscan, std::span<std::uint8_t> out);
// Gaussian of one B-scan (ascans x depth, depth contiguous) into `out`; `rows` is scratch of
// ascans x depth.
void gaussian5x5_bscan(std::span<const std::uint8_t> in, std::uint32_t ascans, std::uint32_t depth,
                       const GaussianTaps& taps, std::span<std::uint8_t> out,
                       std::vector<std::uint32_t>& rows);

}  // namespace ioct::gpu::filters
