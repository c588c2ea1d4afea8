#include "ioct/gpu/instruments/cuda_instrument_detector.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <cub/block/block_scan.cuh>
#include <cub/warp/warp_reduce.cuh>
#include <cuda/functional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include "ioct/gpu/instruments/column_classification.hpp"

namespace ioct::gpu::instruments {
namespace {

// Histogram: blocks of kHistogramThreads, each over kHistogramWords 16-byte words of one B-scan
// (a B-scan of 512 x 688 px: 22 blocks), so the whole device works on it, not one block per
// B-scan. The last block of a B-scan to finish takes its median: the floor.
constexpr int kHistogramThreads = 256;
constexpr std::size_t kHistogramWords = 4 * kHistogramThreads;
// Columns: a warp per A-scan (its px read together, the searches by ballots), a few per block.
// A thread per A-scan walking its column alone kept 2 warps per SM waiting on one load after
// another: 111 us per group on the H200, against a few us for reading the group once.
constexpr int kColumnWarps = 4;
// The columns' shared memory without opting in to more: A-scans up to 12,288 px.
constexpr std::size_t kMaxSharedBytes = 48 * 1024;
constexpr unsigned kFullMask = 0xFFFFFFFFu;

__device__ __forceinline__ void count_bytes(std::uint32_t* histogram, std::uint32_t word) {
#pragma unroll
  for (int k = 0; k < 4; ++k) atomicAdd(&histogram[(word >> (8 * k)) & 0xFFu], 1u);
}

// Adds part blockIdx.x of B-scan blockIdx.y to histograms[blockIdx.y][256]; the B-scan's last
// part to finish writes floors[blockIdx.y], its median (median_of_histogram's level). histograms
// and parts_done (one count per B-scan) are zeroed before.
__global__ void histogram_bscans(const std::uint8_t* bscans, std::size_t pixels,
                                 std::uint32_t* histograms, std::uint32_t* parts_done,
                                 std::uint8_t* floors) {
  static_assert(kHistogramThreads == 256, "a thread per level when the median is taken");
  __shared__ std::uint32_t histogram[256];
  __shared__ bool last_part;
  __shared__ int level;
  using Scan = cub::BlockScan<std::uint32_t, kHistogramThreads>;
  __shared__ typename Scan::TempStorage scan_storage;
  histogram[threadIdx.x] = 0;
  __syncthreads();
  const std::uint8_t* bscan = bscans + blockIdx.y * pixels;
  const std::size_t begin = std::size_t{blockIdx.x} * kHistogramWords * 16;
  const std::size_t end = min(begin + kHistogramWords * 16, pixels);
  // 16-byte loads where the B-scan is 16-byte aligned (every B-scan of the default geometry).
  const bool vectorised = reinterpret_cast<std::uintptr_t>(bscan) % 16 == 0;
  const std::size_t vector_end = vectorised ? begin + (end - begin) / 16 * 16 : begin;
  for (std::size_t i = begin + 16 * threadIdx.x; i < vector_end; i += 16 * blockDim.x) {
    const uint4 v = __ldg(reinterpret_cast<const uint4*>(bscan + i));
    count_bytes(histogram, v.x);
    count_bytes(histogram, v.y);
    count_bytes(histogram, v.z);
    count_bytes(histogram, v.w);
  }
  for (std::size_t i = vector_end + threadIdx.x; i < end; i += blockDim.x)
    atomicAdd(&histogram[bscan[i]], 1u);
  __syncthreads();
  std::uint32_t* total = histograms + 256 * std::size_t{blockIdx.y};
  if (histogram[threadIdx.x] != 0) atomicAdd(&total[threadIdx.x], histogram[threadIdx.x]);
  // The usual last-block pattern: the counts are visible to the block that sees the last part
  // done.
  __threadfence();
  __syncthreads();
  if (threadIdx.x == 0) {
    last_part = atomicAdd(&parts_done[blockIdx.y], 1u) == gridDim.x - 1;
    level = 255;
  }
  __syncthreads();
  if (!last_part) return;
  __threadfence();
  // The first level whose running count reaches half of the px (median_of_histogram).
  const std::uint32_t count = __ldcg(&total[threadIdx.x]);
  std::uint32_t running = 0;
  Scan(scan_storage).InclusiveSum(count, running);
  const std::uint64_t half = (std::uint64_t{pixels} + 1) / 2;
  if (running >= half && (threadIdx.x == 0 || running - count < half)) level = threadIdx.x;
  __syncthreads();
  if (threadIdx.x == 0) floors[blockIdx.y] = static_cast<std::uint8_t>(level);
}

using WarpReduce = cub::WarpReduce<int>;

// Warp collectives over one column held in shared memory, for classify_column_warp.
struct WarpColumn {
  const std::uint8_t* px;  // the column, `depth` bytes
  int depth;
  int lane;
  WarpReduce::TempStorage* reduce;  // the warp's own

  // The first z in [from, depth) where pred(z) holds, or -1: 32 candidates per ballot.
  template <class Pred>
  __device__ int first(int from, Pred pred) const {
    for (int base = from; base < depth; base += 32) {
      const int z = base + lane;
      const unsigned hits = __ballot_sync(kFullMask, z < depth && pred(z));
      if (hits != 0) return base + __ffs(static_cast<int>(hits)) - 1;
    }
    return -1;
  }
  // The last z in (above, to] where pred(z) holds, or -1.
  template <class Pred>
  __device__ int last(int to, int above, Pred pred) const {
    for (int top = to; top > above; top -= 32) {
      const int z = top - lane;
      const unsigned hits = __ballot_sync(kFullMask, z > above && pred(z));
      if (hits != 0) return top - (__ffs(static_cast<int>(hits)) - 1);
    }
    return -1;
  }
  // The sum over z in [from, to) of px - floor, in every lane (integers: any order is exact).
  __device__ int sum_above_floor(int from, int to, int floor_level) const {
    int sum = 0;
    for (int z = from + lane; z < to; z += 32) sum += px[z] - floor_level;
    return everywhere(WarpReduce(*reduce).Sum(sum));
  }
  // The largest px in [from, to), in every lane (0 for an empty range).
  __device__ int max_of(int from, int to) const {
    int m = 0;
    for (int z = from + lane; z < to; z += 32) m = max(m, static_cast<int>(px[z]));
    return everywhere(WarpReduce(*reduce).Reduce(m, ::cuda::maximum<>{}));
  }
  // Lane 0's reduction, in every lane; the temporary storage free again after it.
  __device__ static int everywhere(int lane0) {
    const int all = __shfl_sync(kFullMask, lane0, 0);
    __syncwarp();
    return all;
  }
};

// classify_column (column_classification.hpp) by a warp: each of its sequential walks becomes
// the first or last index where the walk's condition holds, found 32 px at a time, and its sums
// and maximum warp reductions of the same integers. Every lane returns the same finding, the
// CPU's to the bit (InstrumentsCudaVsCpu.*, random columns included).
__device__ ColumnFinding classify_column_warp(const WarpColumn& c, const ColumnParams& p,
                                              int floor_level) {
  ColumnFinding out;
  const std::uint8_t* px = c.px;
  const int depth = p.depth;
  const int object_level = floor_level + p.object_margin;
  const int dark_level = floor_level + p.dark_margin;
  const int top = c.first(p.skip_top, [&](int z) { return px[z] >= object_level; });
  if (top < 0) return out;
  // The first object's end: the first start, from the top, of `gap` dark px in a row (where the
  // walk's run of dark px first reaches `gap`).
  const int end = c.first(top, [&](int z) {
    if (z + p.gap > depth) return false;
    for (int k = 0; k < p.gap; ++k) {
      if (px[z + k] > dark_level) return false;
    }
    return true;
  });
  // The column's last bright px below the top (the top itself if none).
  int last = c.last(depth - 1, top, [&](int z) { return px[z] >= object_level; });
  if (last < 0) last = top;
  if (depth - 1 - last >= p.min_shadow && last - top <= p.max_reflex) {
    const int below_sum = c.sum_above_floor(last + 1, depth, floor_level);
    if (2 * below_sum <= p.dark_margin * (depth - 1 - last)) {
      // Climbing from the last bright px while the px rise: the first px going up, at or below
      // the top, with no brighter px just above it.
      const int peak = c.last(last, top - 1, [&](int z) { return z == top || px[z - 1] <= px[z]; });
      const int v0 = peak > 0 ? px[peak - 1] : px[peak];
      const int v2 = peak + 1 < depth ? px[peak + 1] : px[peak];
      out.kind = ColumnKind::shadow;
      out.reflex_px = parabola_peak(peak, v0, px[peak], v2);
      return out;
    }
  }
  if (end < 0 || end - top > p.max_reflex) return out;
  const int next = c.first(end, [&](int z) { return px[z] >= object_level; });
  if (next < 0 || next - end < p.partial_gap) return out;
  // The object's brightest px, the first of equals (top when the object is empty).
  const int brightest = c.max_of(top, end);
  int peak = c.first(top, [&](int z) { return z < end && px[z] == brightest; });
  if (peak < 0 || end == top) peak = top;
  if (px[peak] < floor_level + p.partial_reflex_margin) return out;
  const int gap_sum = c.sum_above_floor(end, next, floor_level);
  if (2 * gap_sum > p.dark_margin * (next - end)) return out;
  out.kind = ColumnKind::partial;
  out.reflex_px = 0.5f * static_cast<float>(top + end - 1);
  out.front_px = static_cast<float>(top);
  return out;
}

// A-scans of B-scan blockIdx.y, a warp each (kColumnWarps per block): the column into shared
// memory (coalesced), then its kind, reflex and translucent front against the B-scan's floor.
__global__ void classify_columns(const std::uint8_t* bscans, std::uint32_t ascans,
                                 ColumnParams params, const std::uint8_t* floors,
                                 std::uint8_t* kinds, float* reflexes, float* fronts) {
  extern __shared__ std::uint8_t columns[];
  __shared__ WarpReduce::TempStorage reduce[kColumnWarps];
  const int warp = static_cast<int>(threadIdx.x) / 32;
  const int lane = static_cast<int>(threadIdx.x) % 32;
  const std::uint32_t b = blockIdx.y;
  const std::uint32_t a = blockIdx.x * kColumnWarps + static_cast<std::uint32_t>(warp);
  if (a >= ascans) return;  // whole warps: no block barrier follows
  const int depth = params.depth;
  // Each warp's column at a 16-byte multiple in shared memory.
  std::uint8_t* px = columns + static_cast<std::size_t>(warp) * ((depth + 15) / 16 * 16);
  const std::size_t pixels = std::size_t{ascans} * static_cast<std::size_t>(depth);
  const std::uint8_t* column =
      bscans + b * pixels + std::size_t{a} * static_cast<std::size_t>(depth);
  if (reinterpret_cast<std::uintptr_t>(column) % 4 == 0) {
    const int words = depth / 4;
    for (int w = lane; w < words; w += 32) {
      reinterpret_cast<std::uint32_t*>(px)[w] =
          __ldg(reinterpret_cast<const std::uint32_t*>(column) + w);
    }
    for (int z = 4 * words + lane; z < depth; z += 32) px[z] = column[z];
  } else {
    for (int z = lane; z < depth; z += 32) px[z] = column[z];
  }
  __syncwarp();
  const ColumnFinding c =
      classify_column_warp(WarpColumn{px, depth, lane, &reduce[warp]}, params, floors[b]);
  if (lane == 0) {
    kinds[std::size_t{b} * ascans + a] = static_cast<std::uint8_t>(c.kind);
    reflexes[std::size_t{b} * ascans + a] = c.reflex_px;
    fronts[std::size_t{b} * ascans + a] = c.front_px;
  }
}

// Throws BackendUnavailable without a CUDA device (before any CUDA object is made).
void require_device() {
  int devices = 0;
  const cudaError_t status = cudaGetDeviceCount(&devices);
  if (status != cudaSuccess) {
    cudaGetLastError();
    throw BackendUnavailable("backend cuda: no CUDA device: " + cuda::describe(status));
  }
  if (devices == 0) throw BackendUnavailable("backend cuda: no CUDA device is present");
}

}  // namespace

CudaInstrumentDetector::CudaInstrumentDetector(const InstrumentConfig& config,
                                               const VolumeSampling& sampling)
    : InstrumentDetector((require_device(), config), sampling) {}

void CudaInstrumentDetector::classify(VolumeRef volume, BscanSpan group, const ColumnParams& params,
                                      InstrumentFindings&) {
  const VolumeDims& dims = volume.dims();
  const std::size_t ascans = dims.ascans;
  const std::size_t columns = std::size_t{group.count} * ascans;
  const std::size_t shared_bytes = kColumnWarps * ((std::size_t{dims.depth} + 15) / 16 * 16);
  if (shared_bytes > kMaxSharedBytes) {
    throw std::invalid_argument("instruments: A-scans of " + std::to_string(dims.depth) +
                                " px are deeper than the CUDA detection takes (" +
                                std::to_string(kMaxSharedBytes / kColumnWarps) + " px)");
  }
  // One block for what comes back, so it comes back in one copy: reflexes, fronts (floats
  // first, aligned), kinds, floors.
  results_.resize(2 * columns + (columns + group.count + sizeof(float) - 1) / sizeof(float));
  float* reflexes = results_.data();
  float* fronts = reflexes + columns;
  auto* kinds = reinterpret_cast<std::uint8_t*>(fronts + columns);
  std::uint8_t* floors = kinds + columns;
  cudaStream_t stream = stream_.get();
  const std::uint8_t* group_pixels = nullptr;
  if (volume.is_device()) {
    // In place, after whatever its stream has still to write into it.
    IOCT_CUDA_CHECK(cudaEventRecord(volume_ready_.get(), volume.stream()));
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream, volume_ready_.get(), 0));
    group_pixels = volume.device() + std::size_t{group.first} * dims.bscan_bytes();
  } else {
    bscans_.resize(columns * dims.depth);
    cuda::copy_async(bscans_.data(), volume.host().bscan(group.first).data(), bscans_.bytes(),
                     cudaMemcpyHostToDevice, stream, cuda::Payload::volume,
                     "instruments: the group's B-scans to the device");
    group_pixels = bscans_.data();
  }
  const std::size_t pixels = ascans * dims.depth;
  // The B-scans' histograms, then their parts' counts: zeroed together.
  histograms_.resize(std::size_t{group.count} * 257);
  std::uint32_t* parts_done = histograms_.data() + std::size_t{group.count} * 256;
  IOCT_CUDA_CHECK(cudaMemsetAsync(histograms_.data(), 0, histograms_.bytes(), stream));
  const dim3 parts(
      static_cast<unsigned>((pixels + kHistogramWords * 16 - 1) / (kHistogramWords * 16)),
      group.count);
  histogram_bscans<<<parts, kHistogramThreads, 0, stream>>>(group_pixels, pixels,
                                                            histograms_.data(), parts_done, floors);
  cuda::check_launch("instruments: histogram_bscans");
  const dim3 columns_grid(static_cast<unsigned>((ascans + kColumnWarps - 1) / kColumnWarps),
                          group.count);
  classify_columns<<<columns_grid, 32 * kColumnWarps, shared_bytes, stream>>>(
      group_pixels, static_cast<std::uint32_t>(ascans), params, floors, kinds, reflexes, fronts);
  cuda::check_launch("instruments: classify_columns");
  download_.add(results_.data(), (2 * columns) * sizeof(float) + columns + group.count);
  download_.enqueue(stream, cuda::Payload::other,
                    "instruments: the A-scans' kinds, reflexes, fronts and floors to the host");
  in_flight_ = {group, ascans};
}

void CudaInstrumentDetector::collect(InstrumentFindings& findings) {
  if (!in_flight_) return;
  const auto [group, ascans] = *std::exchange(in_flight_, std::nullopt);
  download_.wait();
  const std::size_t columns = std::size_t{group.count} * ascans;
  if (findings.ascans != ascans || group.end() > findings.bscans) {
    // Findings reset for other dimensions since the group began: its classes have no place there.
    throw std::logic_error("instruments: the findings changed dimensions while a group was begun");
  }
  const std::byte* block = download_.piece(0).data();
  const std::size_t offset = std::size_t{group.first} * ascans;
  static_assert(sizeof(ColumnKind) == 1, "the kernel writes one byte per A-scan's kind");
  std::memcpy(findings.reflex_px.data() + offset, block, columns * sizeof(float));
  std::memcpy(findings.front_px.data() + offset, block + columns * sizeof(float),
              columns * sizeof(float));
  std::memcpy(findings.columns.data() + offset, block + 2 * columns * sizeof(float), columns);
  std::memcpy(findings.floor.data() + group.first, block + 2 * columns * sizeof(float) + columns,
              group.count);
}

}  // namespace ioct::gpu::instruments
