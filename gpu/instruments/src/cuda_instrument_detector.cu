#include "ioct/gpu/instruments/cuda_instrument_detector.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>

#include "ioct/gpu/instruments/column_classification.hpp"

namespace ioct::gpu::instruments {
namespace {

// Histogram: blocks of kHistogramThreads, each over kHistogramWords 16-byte words of one B-scan
// (a B-scan of 512 x 688 px: 22 blocks), so the whole device works on it, not one block per
// B-scan.
constexpr int kHistogramThreads = 256;
constexpr std::size_t kHistogramWords = 4 * kHistogramThreads;
// Columns: one thread per A-scan, small blocks so a group's 8192 A-scans spread over every SM.
constexpr int kColumnThreads = 64;

__device__ __forceinline__ void count_bytes(std::uint32_t* histogram, std::uint32_t word) {
#pragma unroll
  for (int k = 0; k < 4; ++k) atomicAdd(&histogram[(word >> (8 * k)) & 0xFFu], 1u);
}

// Adds part blockIdx.x of B-scan blockIdx.y to histograms[blockIdx.y][256] (zeroed before).
__global__ void histogram_bscans(const std::uint8_t* bscans, std::size_t pixels,
                                 std::uint32_t* histograms) {
  __shared__ std::uint32_t histogram[256];
  for (int i = threadIdx.x; i < 256; i += blockDim.x) histogram[i] = 0;
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
  for (int i = threadIdx.x; i < 256; i += blockDim.x) {
    if (histogram[i] != 0) atomicAdd(&total[i], histogram[i]);
  }
}

// A-scans of B-scan blockIdx.y, one per thread: the B-scan's floor (its histogram's median), then
// each column's kind, reflex and translucent front.
__global__ void classify_columns(const std::uint8_t* bscans, std::uint32_t ascans,
                                 ColumnParams params, const std::uint32_t* histograms,
                                 std::uint8_t* kinds, float* reflexes, float* fronts,
                                 std::uint8_t* floors) {
  __shared__ int floor_level;
  const std::uint32_t b = blockIdx.y;
  const std::size_t pixels = std::size_t{ascans} * static_cast<std::size_t>(params.depth);
  if (threadIdx.x == 0) {
    floor_level = median_of_histogram(histograms + 256 * std::size_t{b}, pixels);
    if (blockIdx.x == 0) floors[b] = static_cast<std::uint8_t>(floor_level);
  }
  __syncthreads();
  const std::uint32_t a = blockIdx.x * blockDim.x + threadIdx.x;
  if (a >= ascans) return;
  const ColumnFinding c =
      classify_column(bscans + b * pixels + std::size_t{a} * params.depth, params, floor_level);
  kinds[std::size_t{b} * ascans + a] = static_cast<std::uint8_t>(c.kind);
  reflexes[std::size_t{b} * ascans + a] = c.reflex_px;
  fronts[std::size_t{b} * ascans + a] = c.front_px;
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
                                      InstrumentFindings& findings) {
  const VolumeDims& dims = volume.dims();
  const std::size_t ascans = dims.ascans;
  const std::size_t columns = std::size_t{group.count} * ascans;
  kinds_.resize(columns);
  reflexes_.resize(columns);
  fronts_.resize(columns);
  floors_.resize(group.count);
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
  histograms_.resize(std::size_t{group.count} * 256);
  IOCT_CUDA_CHECK(cudaMemsetAsync(histograms_.data(), 0, histograms_.bytes(), stream));
  const dim3 parts(
      static_cast<unsigned>((pixels + kHistogramWords * 16 - 1) / (kHistogramWords * 16)),
      group.count);
  histogram_bscans<<<parts, kHistogramThreads, 0, stream>>>(group_pixels, pixels,
                                                            histograms_.data());
  cuda::check_launch("instruments: histogram_bscans");
  const dim3 columns_grid(static_cast<unsigned>((ascans + kColumnThreads - 1) / kColumnThreads),
                          group.count);
  classify_columns<<<columns_grid, kColumnThreads, 0, stream>>>(
      group_pixels, static_cast<std::uint32_t>(ascans), params, histograms_.data(), kinds_.data(),
      reflexes_.data(), fronts_.data(), floors_.data());
  cuda::check_launch("instruments: classify_columns");
  const std::size_t kinds = download_.add(kinds_.data(), kinds_.bytes());
  const std::size_t reflexes = download_.add(reflexes_.data(), reflexes_.bytes());
  const std::size_t fronts = download_.add(fronts_.data(), fronts_.bytes());
  const std::size_t floors = download_.add(floors_.data(), floors_.bytes());
  download_.fetch(stream, cuda::Payload::other,
                  "instruments: the A-scans' kinds, reflexes, fronts and floors to the host");
  const std::size_t offset = std::size_t{group.first} * ascans;
  const auto place = [&](std::size_t piece, void* destination) {
    const std::span<const std::byte> bytes = download_.piece(piece);
    std::memcpy(destination, bytes.data(), bytes.size());
  };
  static_assert(sizeof(ColumnKind) == 1, "the kernel writes one byte per A-scan's kind");
  place(kinds, findings.columns.data() + offset);
  place(reflexes, findings.reflex_px.data() + offset);
  place(fronts, findings.front_px.data() + offset);
  place(floors, findings.floor.data() + group.first);
}

}  // namespace ioct::gpu::instruments
