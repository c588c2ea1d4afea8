// CUDA kernels of the volume filters. See cuda_volume_filter.hpp for the thread layout and
// median_networks.hpp for the selection networks.
#include <algorithm>
#include <cstdint>

#include "filter_kernels_probe.hpp"
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#include "ioct/gpu/filters/median_networks.hpp"

namespace ioct::gpu::filters {

// Four u8 voxels in one register; min and max are byte-wise SIMD.
struct U8x4 {
  std::uint32_t bits;
};
__device__ __forceinline__ U8x4 lane_min(U8x4 a, U8x4 b) {
  return {__vminu4(a.bits, b.bits)};
}
__device__ __forceinline__ U8x4 lane_max(U8x4 a, U8x4 b) {
  return {__vmaxu4(a.bits, b.bits)};
}

// The same four voxels as two registers of two 16-bit lanes.
struct U16x2x2 {
  std::uint32_t low;   // voxels 0, 1
  std::uint32_t high;  // voxels 2, 3
};
__device__ __forceinline__ U16x2x2 lane_min(U16x2x2 a, U16x2x2 b) {
  return {__vminu2(a.low, b.low), __vminu2(a.high, b.high)};
}
__device__ __forceinline__ U16x2x2 lane_max(U16x2x2 a, U16x2x2 b) {
  return {__vmaxu2(a.low, b.low), __vmaxu2(a.high, b.high)};
}

// The same, each 16-bit lane holding the half-precision number 1024 + v (bits 0x6400 | v): the
// order of these numbers is the order of v, and min/max run on the half-precision units.
struct F16x2x2 {
  std::uint32_t low;
  std::uint32_t high;
};
__device__ __forceinline__ std::uint32_t min_f16x2(std::uint32_t a, std::uint32_t b) {
  std::uint32_t d;
  asm("min.f16x2 %0, %1, %2;" : "=r"(d) : "r"(a), "r"(b));
  return d;
}
__device__ __forceinline__ std::uint32_t max_f16x2(std::uint32_t a, std::uint32_t b) {
  std::uint32_t d;
  asm("max.f16x2 %0, %1, %2;" : "=r"(d) : "r"(a), "r"(b));
  return d;
}
__device__ __forceinline__ F16x2x2 lane_min(F16x2x2 a, F16x2x2 b) {
  return {min_f16x2(a.low, b.low), min_f16x2(a.high, b.high)};
}
__device__ __forceinline__ F16x2x2 lane_max(F16x2x2 a, F16x2x2 b) {
  return {max_f16x2(a.low, b.low), max_f16x2(a.high, b.high)};
}

namespace {

// Conversions between four packed bytes and the lane types (__byte_perm selector: one nibble per
// result byte, 0-3 from the first operand, 4-7 from the second; here the second is 0).
template <class Lane>
__device__ __forceinline__ Lane from_bytes(std::uint32_t bytes);
template <>
__device__ __forceinline__ U8x4 from_bytes<U8x4>(std::uint32_t bytes) {
  return {bytes};
}
template <>
__device__ __forceinline__ U16x2x2 from_bytes<U16x2x2>(std::uint32_t bytes) {
  return {__byte_perm(bytes, 0, 0x4140), __byte_perm(bytes, 0, 0x4342)};
}
template <>
__device__ __forceinline__ F16x2x2 from_bytes<F16x2x2>(std::uint32_t bytes) {
  return {__byte_perm(bytes, 0, 0x4140) | 0x64006400u, __byte_perm(bytes, 0, 0x4342) | 0x64006400u};
}
__device__ __forceinline__ std::uint32_t to_bytes(U8x4 v) {
  return v.bits;
}
__device__ __forceinline__ std::uint32_t to_bytes(F16x2x2 v) {
  return __byte_perm(v.low, v.high, 0x6420);
}
__device__ __forceinline__ std::uint32_t to_bytes(U16x2x2 v) {
  return __byte_perm(v.low, v.high, 0x6420);
}

__device__ __forceinline__ std::uint32_t clamp_u32(std::int64_t i, std::uint32_t size) {
  return static_cast<std::uint32_t>(i < 0 ? 0 : (i >= size ? size - 1 : i));
}

struct Dims {
  std::uint32_t bscans, ascans, depth;
  std::uint32_t words;  // ceil(depth / 4): threads along depth
};

// Bytes [d0 - 1, d0 + 4] of one row (depth clamped at both ends) as three packed values: the
// voxels d0..d0+3 shifted by -1, 0 and +1 in depth.
__device__ __forceinline__ void load_row(const std::uint8_t* row, std::uint32_t d0,
                                         const Dims& dims, bool aligned_interior,
                                         std::uint32_t (&shifted)[3]) {
  if (aligned_interior) {
    const auto* words = reinterpret_cast<const std::uint32_t*>(row + d0);
    const std::uint32_t previous = __ldg(words - 1);
    const std::uint32_t current = __ldg(words);
    const std::uint32_t next = __ldg(words + 1);
    shifted[0] = __byte_perm(previous, current, 0x6543);
    shifted[1] = current;
    shifted[2] = __byte_perm(current, next, 0x4321);
    return;
  }
  std::uint32_t b[6];
#pragma unroll
  for (int k = 0; k < 6; ++k) b[k] = __ldg(row + clamp_u32(std::int64_t{d0} + k - 1, dims.depth));
  shifted[0] = b[0] | (b[1] << 8) | (b[2] << 16) | (b[3] << 24);
  shifted[1] = b[1] | (b[2] << 8) | (b[3] << 16) | (b[4] << 24);
  shifted[2] = b[2] | (b[3] << 8) | (b[4] << 16) | (b[5] << 24);
}

// The 3x3 plane (A-scans a-1..a+1, depth d-1..d+1, clamped) of B-scan z around the thread's four
// voxels, sorted per lane.
template <class Lane>
__device__ __forceinline__ void load_sorted_plane(const std::uint8_t* in, std::uint32_t z,
                                                  std::uint32_t a, std::uint32_t d0,
                                                  const Dims& dims, bool aligned_interior,
                                                  Lane (&plane)[9]) {
#pragma unroll
  for (int da = -1; da <= 1; ++da) {
    const std::uint32_t row_a = clamp_u32(std::int64_t{a} + da, dims.ascans);
    const std::uint8_t* row = in + (std::size_t{z} * dims.ascans + row_a) * dims.depth;
    std::uint32_t shifted[3];
    load_row(row, d0, dims, aligned_interior, shifted);
#pragma unroll
    for (int k = 0; k < 3; ++k) plane[3 * (da + 1) + k] = from_bytes<Lane>(shifted[k]);
  }
  sort9(plane);
}

__device__ __forceinline__ void store_word(std::uint8_t* row, std::uint32_t d0, const Dims& dims,
                                           bool aligned_interior, std::uint32_t bytes) {
  if (aligned_interior || (dims.depth % 4 == 0)) {
    *reinterpret_cast<std::uint32_t*>(row + d0) = bytes;
    return;
  }
  for (std::uint32_t k = 0; k < 4 && d0 + k < dims.depth; ++k)
    row[d0 + k] = (bytes >> (8 * k)) & 0xFF;
}

// Algorithm 2 of median_networks.hpp. Thread: 4 voxels (one word) of A-scan `a`, output
// B-scans [z_begin, z_end) of its walk.
template <class Lane>
__global__ void median_sorted_runs_kernel(const std::uint8_t* __restrict__ in,
                                          std::uint8_t* __restrict__ out, Dims dims,
                                          std::uint32_t first_output, std::uint32_t end_output,
                                          std::uint32_t walk) {
  const std::uint64_t thread = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (thread >= std::uint64_t{dims.ascans} * dims.words) return;
  const std::uint32_t word = static_cast<std::uint32_t>(thread % dims.words);
  const std::uint32_t a = static_cast<std::uint32_t>(thread / dims.words);
  const std::uint32_t d0 = 4 * word;
  const std::uint32_t z_begin = first_output + blockIdx.y * walk;
  if (z_begin >= end_output) return;
  const std::uint32_t z_end = min(z_begin + walk, end_output);
  // Whole words on both sides inside the row, rows word-aligned: plain 32-bit loads.
  const bool aligned_interior = dims.depth % 4 == 0 && d0 >= 4 && d0 + 8 <= dims.depth;

  Lane below[9], centre[9];
  load_sorted_plane(in, z_begin == 0 ? 0 : z_begin - 1, a, d0, dims, aligned_interior, below);
  load_sorted_plane(in, z_begin, a, d0, dims, aligned_interior, centre);
  for (std::uint32_t z = z_begin; z < z_end; z += 2) {
    // Output z: planes z-1, z, z+1. Output z+1: planes z, z+1, z+2. Both contain the merge of
    // planes z and z+1.
    Lane above[9];
    load_sorted_plane(in, min(z + 1, dims.bscans - 1), a, d0, dims, aligned_interior, above);
    Lane middle[10];
    merge9_middle10(centre, above, middle);
    std::uint8_t* row = out + (std::size_t{z} * dims.ascans + a) * dims.depth;
    store_word(row, d0, dims, aligned_interior, to_bytes(select_median(middle, below)));
    if (z + 1 >= z_end) break;
    Lane next[9];
    load_sorted_plane(in, min(z + 2, dims.bscans - 1), a, d0, dims, aligned_interior, next);
    row += std::size_t{dims.ascans} * dims.depth;
    store_word(row, d0, dims, aligned_interior, to_bytes(select_median(middle, next)));
#pragma unroll
    for (int k = 0; k < 9; ++k) {
      below[k] = above[k];
      centre[k] = next[k];
    }
  }
}

// The second paper's median: 3x3 within each B-scan. Thread: 4 voxels (one word) of A-scan `a` of
// one output B-scan; the plane's nine shifted words sorted per lane, the middle one kept.
template <class Lane>
__global__ void median_bscan_kernel(const std::uint8_t* __restrict__ in,
                                    std::uint8_t* __restrict__ out, Dims dims,
                                    std::uint32_t first_output) {
  const std::uint64_t thread = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (thread >= std::uint64_t{dims.ascans} * dims.words) return;
  const std::uint32_t word = static_cast<std::uint32_t>(thread % dims.words);
  const std::uint32_t a = static_cast<std::uint32_t>(thread / dims.words);
  const std::uint32_t d0 = 4 * word;
  const std::uint32_t z = first_output + blockIdx.y;
  const bool aligned_interior = dims.depth % 4 == 0 && d0 >= 4 && d0 + 8 <= dims.depth;
  Lane plane[9];
  load_sorted_plane(in, z, a, d0, dims, aligned_interior, plane);
  std::uint8_t* row = out + (std::size_t{z} * dims.ascans + a) * dims.depth;
  store_word(row, d0, dims, aligned_interior, to_bytes(plane[4]));
}

// The first paper's algorithm: one voxel per thread, walking along B-scans, each output's 27
// values gathered and reduced by forgetful selection (median_networks.hpp, algorithm 1).
__global__ void median_forgetful_kernel(const std::uint8_t* __restrict__ in,
                                        std::uint8_t* __restrict__ out, Dims dims,
                                        std::uint32_t first_output, std::uint32_t end_output,
                                        std::uint32_t walk) {
  const std::uint64_t thread = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (thread >= std::uint64_t{dims.ascans} * dims.depth) return;
  const std::uint32_t d = static_cast<std::uint32_t>(thread % dims.depth);
  const std::uint32_t a = static_cast<std::uint32_t>(thread / dims.depth);
  const std::uint32_t z_begin = first_output + blockIdx.y * walk;
  if (z_begin >= end_output) return;
  const std::uint32_t z_end = min(z_begin + walk, end_output);
  std::uint32_t offsets[9];  // row offsets within a B-scan, then depth
  int n = 0;
#pragma unroll
  for (int da = -1; da <= 1; ++da) {
#pragma unroll
    for (int dd = -1; dd <= 1; ++dd) {
      offsets[n++] = clamp_u32(std::int64_t{a} + da, dims.ascans) * dims.depth +
                     clamp_u32(std::int64_t{d} + dd, dims.depth);
    }
  }
  const std::size_t bscan_pixels = std::size_t{dims.ascans} * dims.depth;
  for (std::uint32_t z = z_begin; z < z_end; ++z) {
    std::uint32_t v[27];
#pragma unroll
    for (int dz = -1; dz <= 1; ++dz) {
      const std::uint32_t plane = clamp_u32(std::int64_t{z} + dz, dims.bscans);
      const std::uint8_t* base = in + plane * bscan_pixels;
#pragma unroll
      for (int k = 0; k < 9; ++k) v[9 * (dz + 1) + k] = __ldg(base + offsets[k]);
    }
    out[z * bscan_pixels + std::size_t{a} * dims.depth + d] =
        static_cast<std::uint8_t>(median27_forgetful(v));
  }
}

// Gaussian 5x5 in each B-scan, walking like the median: a thread takes 4 depth pixels (one word)
// of one B-scan and walks along kGaussWalk A-scans, keeping the sums along depth of the last five
// rows in registers, so each input row is read and summed once per walk (plus 4 rows of halo).

struct Taps {
  std::uint32_t t0, t1, t2;  // outer, inner, centre
};

// Sums along depth of the thread's 4 pixels in one row.
__device__ __forceinline__ void sums_along_depth(const std::uint8_t* row, std::uint32_t d0,
                                                 const Dims& dims, bool aligned_interior,
                                                 const Taps& taps, std::uint32_t (&sums)[4]) {
  std::uint32_t b[8];  // depth d0 - 2 .. d0 + 5
  if (aligned_interior) {
    const auto* words = reinterpret_cast<const std::uint32_t*>(row + d0);
    const std::uint32_t previous = __ldg(words - 1);
    const std::uint32_t current = __ldg(words);
    const std::uint32_t next = __ldg(words + 1);
    b[0] = previous >> 16 & 0xFF;
    b[1] = previous >> 24;
#pragma unroll
    for (int k = 0; k < 4; ++k) b[2 + k] = current >> (8 * k) & 0xFF;
    b[6] = next & 0xFF;
    b[7] = next >> 8 & 0xFF;
  } else {
#pragma unroll
    for (int k = 0; k < 8; ++k) b[k] = __ldg(row + clamp_u32(std::int64_t{d0} + k - 2, dims.depth));
  }
#pragma unroll
  for (int l = 0; l < 4; ++l) {
    sums[l] = taps.t0 * (b[l] + b[l + 4]) + taps.t1 * (b[l + 1] + b[l + 3]) + taps.t2 * b[l + 2];
  }
}

__global__ void gaussian_kernel(const std::uint8_t* __restrict__ in, std::uint8_t* __restrict__ out,
                                Dims dims, std::uint32_t first_bscan, Taps taps,
                                std::uint32_t walk) {
  const std::uint32_t walks = (dims.ascans + walk - 1) / walk;
  const std::uint64_t thread = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (thread >= std::uint64_t{walks} * dims.words) return;
  const std::uint32_t word = static_cast<std::uint32_t>(thread % dims.words);
  const std::uint32_t a_begin = static_cast<std::uint32_t>(thread / dims.words) * walk;
  const std::uint32_t a_end = min(a_begin + walk, dims.ascans);
  const std::uint32_t d0 = 4 * word;
  const bool aligned_interior = dims.depth % 4 == 0 && d0 >= 4 && d0 + 8 <= dims.depth;
  const std::size_t bscan_offset = std::size_t{first_bscan + blockIdx.y} * dims.ascans * dims.depth;
  const std::uint8_t* src = in + bscan_offset;
  const auto row = [&](std::int64_t a) {
    return src + std::size_t{clamp_u32(a, dims.ascans)} * dims.depth;
  };

  std::uint32_t sums[5][4];  // rows a - 2 .. a + 2
#pragma unroll
  for (int k = 1; k < 5; ++k) {
    sums_along_depth(row(std::int64_t{a_begin} + k - 3), d0, dims, aligned_interior, taps, sums[k]);
  }
  constexpr std::uint32_t kHalf = 1u << (GaussianTaps::kShift - 1);
  for (std::uint32_t a = a_begin; a < a_end; ++a) {
#pragma unroll
    for (int k = 0; k < 4; ++k) {
#pragma unroll
      for (int l = 0; l < 4; ++l) sums[k][l] = sums[k + 1][l];
    }
    sums_along_depth(row(std::int64_t{a} + 2), d0, dims, aligned_interior, taps, sums[4]);
    std::uint32_t bytes = 0;
#pragma unroll
    for (int l = 0; l < 4; ++l) {
      const std::uint32_t sum = taps.t0 * (sums[0][l] + sums[4][l]) +
                                taps.t1 * (sums[1][l] + sums[3][l]) + taps.t2 * sums[2][l] + kHalf;
      bytes |= (sum >> GaussianTaps::kShift) << (8 * l);
    }
    store_word(out + bscan_offset + std::size_t{a} * dims.depth, d0, dims, aligned_interior, bytes);
  }
}

Dims dims_of(VolumeDims v) {
  return {v.bscans, v.ascans, v.depth, (v.depth + 3) / 4};
}

std::uint32_t blocks_for(std::uint64_t threads, std::uint32_t per_block) {
  return static_cast<std::uint32_t>((threads + per_block - 1) / per_block);
}

}  // namespace

cudaError_t probe_filter_kernels() {
  cudaFuncAttributes attributes;
  return cudaFuncGetAttributes(&attributes, gaussian_kernel);
}

std::string_view to_string(MedianKernel kernel) noexcept {
  switch (kernel) {
    case MedianKernel::sorted_runs_u8x4:
      return "sorted_runs_u8x4";
    case MedianKernel::sorted_runs_u16x2:
      return "sorted_runs_u16x2";
    case MedianKernel::sorted_runs_f16x2:
      return "sorted_runs_f16x2";
    case MedianKernel::forgetful:
      return "forgetful";
  }
  return "?";
}

void enqueue_median(const std::uint8_t* in, std::uint8_t* out, VolumeDims volume,
                    BscanRange outputs, MedianWindow window, const CudaFilterTuning& tuning,
                    cudaStream_t stream) {
  if (outputs.count == 0 || volume.ascans == 0 || volume.depth == 0) return;
  const Dims dims = dims_of(volume);
  if (window == MedianWindow::bscan_3x3) {
    constexpr std::uint32_t kThreads = 256;
    constexpr std::uint32_t kMaxGridY = 65535;
    for (std::uint32_t first = outputs.first; first < outputs.end(); first += kMaxGridY) {
      const dim3 grid(blocks_for(std::uint64_t{dims.ascans} * dims.words, kThreads),
                      std::min(kMaxGridY, outputs.end() - first));
      median_bscan_kernel<U8x4><<<grid, kThreads, 0, stream>>>(in, out, dims, first);
      cuda::check_launch("median_bscan_kernel");
    }
    return;
  }
  // Walks per launch fit the grid's y dimension (65535).
  const std::uint32_t walk =
      std::max({tuning.bscans_per_thread, 1u, (outputs.count + 65534) / 65535});
  const std::uint32_t walks = (outputs.count + walk - 1) / walk;
  constexpr std::uint32_t kThreads = 256;
  const dim3 sorted_runs_grid(blocks_for(std::uint64_t{dims.ascans} * dims.words, kThreads), walks);
  const auto sorted_runs = [&](auto kernel) {
    kernel<<<sorted_runs_grid, kThreads, 0, stream>>>(in, out, dims, outputs.first, outputs.end(),
                                                      walk);
  };
  switch (tuning.median_kernel) {
    case MedianKernel::sorted_runs_u16x2:
      sorted_runs(median_sorted_runs_kernel<U16x2x2>);
      break;
    case MedianKernel::sorted_runs_f16x2:
      sorted_runs(median_sorted_runs_kernel<F16x2x2>);
      break;
    case MedianKernel::sorted_runs_u8x4:
      sorted_runs(median_sorted_runs_kernel<U8x4>);
      break;
    case MedianKernel::forgetful:
      median_forgetful_kernel<<<dim3(blocks_for(std::uint64_t{dims.ascans} * dims.depth, kThreads),
                                     walks),
                                kThreads, 0, stream>>>(in, out, dims, outputs.first, outputs.end(),
                                                       walk);
      break;
  }
  cuda::check_launch(tuning.median_kernel == MedianKernel::forgetful ? "median_forgetful_kernel"
                                                                     : "median_sorted_runs_kernel");
}

void enqueue_gaussian(const std::uint8_t* in, std::uint8_t* out, VolumeDims volume,
                      BscanRange bscans, const GaussianTaps& taps, const CudaFilterTuning& tuning,
                      cudaStream_t stream) {
  if (bscans.count == 0 || volume.ascans == 0 || volume.depth == 0) return;
  const Dims dims = dims_of(volume);
  const std::uint32_t walk = std::max(tuning.ascans_per_gaussian_thread, 1u);
  const std::uint32_t walks = (dims.ascans + walk - 1) / walk;
  constexpr std::uint32_t kThreads = 128;
  constexpr std::uint32_t kMaxGridY = 65535;
  for (std::uint32_t first = bscans.first; first < bscans.end(); first += kMaxGridY) {
    const dim3 grid(blocks_for(std::uint64_t{walks} * dims.words, kThreads),
                    std::min(kMaxGridY, bscans.end() - first));
    gaussian_kernel<<<grid, kThreads, 0, stream>>>(
        in, out, dims, first, Taps{taps.taps[0], taps.taps[1], taps.taps[2]}, walk);
    cuda::check_launch("gaussian_kernel");
  }
}

void enqueue_volume_filter(const std::uint8_t* in, std::uint8_t* median, std::uint8_t* out,
                           VolumeDims dims, BscanRange outputs, const VolumeFilterConfig& config,
                           const GaussianTaps& taps, const CudaFilterTuning& tuning,
                           cudaStream_t stream) {
  const std::size_t bscan_bytes = std::size_t{dims.ascans} * dims.depth;
  if (config.median && config.gaussian) {
    enqueue_median(in, median, dims, outputs, config.median_window, tuning, stream);
    enqueue_gaussian(median, out, dims, outputs, taps, tuning, stream);
  } else if (config.median) {
    enqueue_median(in, out, dims, outputs, config.median_window, tuning, stream);
  } else if (config.gaussian) {
    enqueue_gaussian(in, out, dims, outputs, taps, tuning, stream);
  } else {
    IOCT_CUDA_CHECK(cudaMemcpyAsync(out + outputs.first * bscan_bytes,
                                    in + outputs.first * bscan_bytes, outputs.count * bscan_bytes,
                                    cudaMemcpyDeviceToDevice, stream));
  }
}

}  // namespace ioct::gpu::filters
