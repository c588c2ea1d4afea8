// The CUDA kernels of the OCT chain, each small and with its parameters spelled out, and the
// functions that launch them (checked). Only the gpu library's .cu files include this.
//
//   sum_spectra          integer column sums of a group's active records (background)
//   update_background    the group's sums into the rolling history; the mean spectrum
//   windowed_background  resampled(background) x window
//   make_spectra         raw -> minus background, resampled, windowed [x dispersion correction]:
//                        the one fused kernel before the FFT
//   log_u8               |X|^2 [mean over repeats] -> dB -> u8, flipped, into B-scan positions
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "ioct/shm/ring_geometry.hpp"

namespace ioct::gpu::cuda {

// Where a group's active records are in its payload [bscan][record][sample].
struct RecordLayout {
  std::uint32_t samples = 0;            // per record
  std::uint32_t records_per_bscan = 0;  // the ring's ascans_per_bscan
  std::uint32_t active_begin = 0;
  std::uint32_t width = 0;  // active records per B-scan
  std::uint32_t rows = 0;   // bscan_count x width: the group's spectra, row = b * width + a
};

// The resampling table on the device (taps == 0: none).
struct DeviceTaps {
  std::uint32_t taps = 0;
  const std::uint32_t* first = nullptr;
  const float* weights = nullptr;
};

// Output B-scans [first, first + count) of a group and where each goes.
struct PixelJob {
  std::uint32_t first = 0;
  std::uint32_t count = 0;
  std::uint32_t repeats = 1;        // input B-scans per output B-scan
  std::uint64_t reversed_mask = 0;  // bit b: input B-scan b was recorded right to left
  std::int32_t
      position[shm::kMaxBscansPerGroup];  // per output B-scan: B-scan in the target; -1: none
};

void launch_sum_spectra(const std::uint16_t* spectra, const RecordLayout& layout,
                        unsigned long long* sums, cudaStream_t stream);

void launch_update_background(const unsigned long long* group_sums, unsigned long long* history,
                              std::uint32_t slot, std::uint32_t used_slots,
                              std::uint64_t total_ascans, std::uint32_t samples, float* background,
                              cudaStream_t stream);

void launch_windowed_background(const float* background, const DeviceTaps& taps,
                                const float* window, std::uint32_t samples, float* out,
                                cudaStream_t stream);

// Real spectra into `real_out` (rows `distance` floats apart), or, with `correction`, complex
// ones into `complex_out` (rows `distance` float2 apart).
void launch_make_spectra(const std::uint16_t* spectra, const RecordLayout& layout,
                         const DeviceTaps& taps, const float* window,
                         const float* windowed_background, const float2* correction,
                         float* real_out, float2* complex_out, std::uint32_t distance,
                         cudaStream_t stream);

// bins: rows (b * width + a) `distance` float2 apart; pixels of output B-scan o, column c, depth
// d go to target[(position[o] * width + c) * depth + d].
void launch_log_u8(const float2* bins, std::uint32_t distance, std::uint32_t width,
                   std::uint32_t depth, const PixelJob& job, float gain, float offset,
                   std::uint8_t* target, cudaStream_t stream);

}  // namespace ioct::gpu::cuda
