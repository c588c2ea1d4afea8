// The CUDA implementation of the volume filters (built only with CUDA), tested bit-exact against
// CpuVolumeFilter.
//
// Median: one thread per 4 consecutive depth pixels of one A-scan, walking along the slow (B-scan)
// axis as in the first paper; the four voxels are packed two per 32-bit register and every
// compare-exchange is a SIMD min/max of two 16-bit lanes. Each B-scan plane of 3x3 values is sorted
// once and kept for the next two outputs, two planes are merged once for two outputs
// (median_networks.hpp, algorithm 2). The paper's per-voxel forgetful selection is kept as a kernel
// for comparison. Gaussian: one thread per 4 depth pixels of a B-scan, walking along A-scans with
// the last five rows' sums along depth in registers; fixed point as on the CPU.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <string_view>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/filters/gaussian_taps.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"

namespace ioct::gpu::filters {

enum class MedianKernel {
  sorted_runs_u16x2,  // algorithm 2, the 4 voxels in two registers of two 16-bit lanes
  sorted_runs_f16x2,  // the same on the half-precision min/max units (lanes hold 1024 + v)
  sorted_runs_u8x4,   // the same with 4 voxels in one register; sm_90 has no byte-SIMD min/max,
                      // so each one is emulated by about ten instructions
  forgetful,          // the paper's algorithm 1, one voxel per thread, all 27 values per output
};

std::string_view to_string(MedianKernel kernel) noexcept;

struct CudaFilterTuning {
  // The defaults are the fastest measured on the H100 (README.md).
  MedianKernel median_kernel = MedianKernel::sorted_runs_u16x2;
  // Output B-scans one thread walks through; its first two planes are overhead, so longer walks
  // do less work, shorter ones make more threads (8: +8 %, 32: +1 %, 64: +8 % time).
  std::uint32_t bscans_per_thread = 16;
  // A-scans one Gaussian thread walks through (plus 4 rows of halo; 32: +3 %, 64: +19 %).
  std::uint32_t ascans_per_gaussian_thread = 16;
};

// Kernel launches on device volumes, for the live pipeline whose volume already lives on the GPU
// and for benchmarks. Enqueued on `stream`; nothing is synchronised. `in` and `out` hold the
// whole volume and are 4-byte aligned (as cudaMalloc returns them); `median` is scratch of the same
// size (unused when the median or the Gaussian is off). Writes output B-scans `outputs` only,
// reading input B-scans inputs_needed_for(outputs).
void enqueue_volume_filter(const std::uint8_t* in, std::uint8_t* median, std::uint8_t* out,
                           VolumeDims dims, BscanRange outputs, const VolumeFilterConfig& config,
                           const GaussianTaps& taps, const CudaFilterTuning& tuning,
                           cudaStream_t stream);

// The two steps alone (benchmarks).
void enqueue_median(const std::uint8_t* in, std::uint8_t* out, VolumeDims dims, BscanRange outputs,
                    MedianWindow window, const CudaFilterTuning& tuning, cudaStream_t stream);
void enqueue_gaussian(const std::uint8_t* in, std::uint8_t* out, VolumeDims dims, BscanRange bscans,
                      const GaussianTaps& taps, const CudaFilterTuning& tuning,
                      cudaStream_t stream);

class CudaVolumeFilter final : public VolumeFilter {
 public:
  // Validates the config (ConfigError). Throws BackendUnavailable when there is no CUDA device
  // (with CUDA's reason) or the device cannot run this build's code.
  explicit CudaVolumeFilter(const VolumeFilterConfig& config, CudaFilterTuning tuning = {});
  ~CudaVolumeFilter() override;

  // Host volumes: the needed input B-scans are copied to the device, filtered, and the output
  // B-scans copied back; the call returns when they are in `out`.
  void filter_volume(const Volume& in, Volume& out) override;
  BscanRange filter_group(const Volume& in, Volume& out, std::uint32_t first_bscan,
                          std::uint32_t count) override;
  // Device refs: enqueued on in's stream (the median's scratch is the filter's own, grown with a
  // synchronising allocation only when a larger volume comes); host refs as above.
  BscanRange filter_group(VolumeRef in, MutableVolumeRef out, BscanRange changed) override;
  const VolumeFilterConfig& config() const noexcept override { return config_; }
  std::string_view backend_name() const noexcept override { return "cuda"; }

 private:
  void run(const Volume& in, Volume& out, BscanRange outputs);
  void reserve(std::size_t bytes);

  VolumeFilterConfig config_;
  CudaFilterTuning tuning_;
  GaussianTaps taps_;
  cudaStream_t stream_ = nullptr;
  cuda::DeviceArray<std::uint8_t> in_;
  cuda::DeviceArray<std::uint8_t> median_;
  cuda::DeviceArray<std::uint8_t> out_;
};

}  // namespace ioct::gpu::filters
