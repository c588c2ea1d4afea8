#include <cstdint>

#include "cuda_kernels.cuh"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/processing/background_removal.hpp"
#include "ioct/gpu/processing/host_device.hpp"

namespace ioct::gpu::cuda {
namespace {

constexpr std::uint32_t kRowsPerSumChunk = 64;  // rows one thread sums before its atomic add

// Each thread sums two neighbouring samples over a chunk of rows; chunks meet in 64-bit atomics,
// which are exact, so the order of addition does not matter.
__global__ void sum_spectra(const std::uint16_t* __restrict__ spectra, RecordLayout layout,
                            unsigned long long* __restrict__ sums) {
  const std::uint32_t pair = blockIdx.y * blockDim.x + threadIdx.x;
  const std::uint32_t s = 2 * pair;
  if (s >= layout.samples) return;
  const std::uint32_t row_begin = blockIdx.x * kRowsPerSumChunk;
  const std::uint32_t row_end = min(row_begin + kRowsPerSumChunk, layout.rows);
  std::uint32_t even = 0;
  std::uint32_t odd = 0;
  for (std::uint32_t row = row_begin; row < row_end; ++row) {
    const std::uint32_t b = row / layout.width;
    const std::uint32_t a = row - b * layout.width;
    const std::size_t record = std::size_t{b} * layout.records_per_bscan + layout.active_begin + a;
    const ushort2 v = *reinterpret_cast<const ushort2*>(spectra + record * layout.samples + s);
    even += v.x;
    odd += v.y;
  }
  atomicAdd(&sums[s], static_cast<unsigned long long>(even));
  atomicAdd(&sums[s + 1], static_cast<unsigned long long>(odd));
}

__global__ void update_background(const unsigned long long* __restrict__ group_sums,
                                  unsigned long long* __restrict__ history, std::uint32_t slot,
                                  std::uint32_t used_slots, std::uint64_t total_ascans,
                                  std::uint32_t samples, float* __restrict__ background) {
  const std::uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= samples) return;
  history[std::size_t{slot} * samples + s] = group_sums[s];
  unsigned long long total = 0;
  for (std::uint32_t h = 0; h < used_slots; ++h) total += history[std::size_t{h} * samples + s];
  background[s] = background_mean(total, total_ascans);
}

__device__ inline float resampled(const float* __restrict__ values, const DeviceTaps& taps,
                                  std::uint32_t j) {
  if (taps.taps == 0) return values[j];
  const float* w = taps.weights + std::size_t{j} * taps.taps;
  const float* v = values + taps.first[j];
  float sum = w[0] * v[0];
  for (std::uint32_t t = 1; t < taps.taps; ++t) sum += w[t] * v[t];
  return sum;
}

__global__ void windowed_background(const float* __restrict__ background, DeviceTaps taps,
                                    const float* __restrict__ window, std::uint32_t samples,
                                    float* __restrict__ out) {
  const std::uint32_t j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= samples) return;
  out[j] = resampled(background, taps, j) * window[j];
}

// The raw value behind output sample j of one record: resampled, or the sample itself.
__device__ inline float raw_value(const std::uint16_t* __restrict__ record, const DeviceTaps& taps,
                                  std::uint32_t j) {
  if (taps.taps == 0) return static_cast<float>(record[j]);
  const float* w = taps.weights + std::size_t{j} * taps.taps;
  const std::uint16_t* v = record + taps.first[j];
  float sum = w[0] * static_cast<float>(v[0]);
  for (std::uint32_t t = 1; t < taps.taps; ++t) sum += w[t] * static_cast<float>(v[t]);
  return sum;
}

// One block per row (spectrum); each thread makes two neighbouring samples, so loads and stores
// are at least 4 and 8 bytes wide.
template <bool kComplex>
__global__ void make_spectra(const std::uint16_t* __restrict__ spectra, RecordLayout layout,
                             DeviceTaps taps, const float* __restrict__ window,
                             const float* __restrict__ windowed_background,
                             const float2* __restrict__ correction, float* __restrict__ real_out,
                             float2* __restrict__ complex_out, std::uint32_t distance) {
  const std::uint32_t row = blockIdx.x;
  const std::uint32_t b = row / layout.width;
  const std::uint32_t a = row - b * layout.width;
  const std::uint16_t* record =
      spectra +
      (std::size_t{b} * layout.records_per_bscan + layout.active_begin + a) * layout.samples;
  for (std::uint32_t j = 2 * threadIdx.x; j < layout.samples; j += 2 * blockDim.x) {
    float v0;
    float v1;
    if (taps.taps == 0) {
      const ushort2 raw = *reinterpret_cast<const ushort2*>(record + j);
      v0 = static_cast<float>(raw.x);
      v1 = static_cast<float>(raw.y);
    } else {
      v0 = raw_value(record, taps, j);
      v1 = raw_value(record, taps, j + 1);
    }
    const float2 w = *reinterpret_cast<const float2*>(window + j);
    const float2 bg = *reinterpret_cast<const float2*>(windowed_background + j);
    v0 = v0 * w.x - bg.x;
    v1 = v1 * w.y - bg.y;
    if constexpr (kComplex) {
      const float4 c = *reinterpret_cast<const float4*>(correction + j);
      *reinterpret_cast<float4*>(complex_out + std::size_t{row} * distance + j) =
          make_float4(v0 * c.x, v0 * c.y, v1 * c.z, v1 * c.w);
    } else {
      *reinterpret_cast<float2*>(real_out + std::size_t{row} * distance + j) = make_float2(v0, v1);
    }
  }
}

// One block per (column, output B-scan); threads along depth.
__global__ void log_u8(const float2* __restrict__ bins, std::uint32_t distance, std::uint32_t width,
                       std::uint32_t depth, PixelJob job, float gain, float offset,
                       std::uint8_t* __restrict__ target) {
  const std::uint32_t column = blockIdx.x;
  const std::uint32_t output = job.first + blockIdx.y;
  const std::int32_t position = job.position[output];
  if (position < 0) return;
  // The bins row of each repeat that lands in this column (reversed repeats are flipped).
  const float2* rows[16];
  for (std::uint32_t r = 0; r < job.repeats; ++r) {
    const std::uint32_t input = output * job.repeats + r;
    const bool reversed = ((job.reversed_mask >> input) & 1u) != 0;
    const std::uint32_t record = reversed ? width - 1 - column : column;
    rows[r] = bins + (std::size_t{input} * width + record) * distance;
  }
  std::uint8_t* out =
      target + (std::size_t{static_cast<std::uint32_t>(position)} * width + column) * depth;
  for (std::uint32_t d = threadIdx.x; d < depth; d += blockDim.x) {
    float power;
    if (job.repeats == 1) {
      const float2 x = rows[0][d];
      power = x.x * x.x + x.y * x.y;
    } else {
      power = 0.0f;
      for (std::uint32_t r = 0; r < job.repeats; ++r) {
        const float2 x = rows[r][d];
        power += x.x * x.x + x.y * x.y;
      }
      power = power / static_cast<float>(job.repeats);
    }
    out[d] = power_to_u8(power, gain, offset);
  }
}

std::uint32_t blocks(std::uint64_t items, std::uint32_t per_block) {
  return static_cast<std::uint32_t>((items + per_block - 1) / per_block);
}

}  // namespace

void launch_sum_spectra(const std::uint16_t* spectra, const RecordLayout& layout,
                        unsigned long long* sums, cudaStream_t stream) {
  constexpr std::uint32_t kThreads = 128;
  // Row chunks along x (up to 2^31 blocks), sample pairs along y (at most 256 blocks).
  const dim3 grid(blocks(layout.rows, kRowsPerSumChunk), blocks(layout.samples / 2, kThreads));
  sum_spectra<<<grid, kThreads, 0, stream>>>(spectra, layout, sums);
  check_launch("sum_spectra");
}

void launch_update_background(const unsigned long long* group_sums, unsigned long long* history,
                              std::uint32_t slot, std::uint32_t used_slots,
                              std::uint64_t total_ascans, std::uint32_t samples, float* background,
                              cudaStream_t stream) {
  constexpr std::uint32_t kThreads = 256;
  update_background<<<blocks(samples, kThreads), kThreads, 0, stream>>>(
      group_sums, history, slot, used_slots, total_ascans, samples, background);
  check_launch("update_background");
}

void launch_windowed_background(const float* background, const DeviceTaps& taps,
                                const float* window, std::uint32_t samples, float* out,
                                cudaStream_t stream) {
  constexpr std::uint32_t kThreads = 256;
  windowed_background<<<blocks(samples, kThreads), kThreads, 0, stream>>>(background, taps, window,
                                                                          samples, out);
  check_launch("windowed_background");
}

void launch_make_spectra(const std::uint16_t* spectra, const RecordLayout& layout,
                         const DeviceTaps& taps, const float* window,
                         const float* windowed_background, const float2* correction,
                         float* real_out, float2* complex_out, std::uint32_t distance,
                         cudaStream_t stream) {
  if (layout.rows == 0) return;
  // Enough threads for one pass over a typical spectrum (1376 samples: 688 pairs).
  const std::uint32_t threads = layout.samples / 2 >= 512 ? 256 : 128;
  if (correction != nullptr) {
    make_spectra<true><<<layout.rows, threads, 0, stream>>>(spectra, layout, taps, window,
                                                            windowed_background, correction,
                                                            real_out, complex_out, distance);
  } else {
    make_spectra<false><<<layout.rows, threads, 0, stream>>>(spectra, layout, taps, window,
                                                             windowed_background, correction,
                                                             real_out, complex_out, distance);
  }
  check_launch("make_spectra");
}

void launch_log_u8(const float2* bins, std::uint32_t distance, std::uint32_t width,
                   std::uint32_t depth, const PixelJob& job, float gain, float offset,
                   std::uint8_t* target, cudaStream_t stream) {
  if (job.count == 0 || width == 0) return;
  const std::uint32_t threads = depth >= 512 ? 256 : 128;
  const dim3 grid(width, job.count);
  log_u8<<<grid, threads, 0, stream>>>(bins, distance, width, depth, job, gain, offset, target);
  check_launch("log_u8");
}

}  // namespace ioct::gpu::cuda
