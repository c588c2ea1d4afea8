#include "ioct/gpu/instruments/cuda_instrument_detector.hpp"

#include <string>

#include "ioct/gpu/instruments/column_classification.hpp"

namespace ioct::gpu::instruments {
namespace {

constexpr int kThreads = 256;

// One block per B-scan of the group: its histogram, its floor, then its A-scans.
__global__ void classify_bscans(const std::uint8_t* bscans, std::uint32_t ascans,
                                ColumnParams params, std::uint8_t* kinds, float* reflexes,
                                std::uint8_t* floors) {
  __shared__ std::uint32_t histogram[256];
  __shared__ int floor_level;
  const std::uint32_t b = blockIdx.x;
  const std::size_t pixels = std::size_t{ascans} * static_cast<std::size_t>(params.depth);
  const std::uint8_t* bscan = bscans + b * pixels;
  for (int i = threadIdx.x; i < 256; i += blockDim.x) histogram[i] = 0;
  __syncthreads();
  for (std::size_t i = threadIdx.x; i < pixels; i += blockDim.x)
    atomicAdd(&histogram[bscan[i]], 1u);
  __syncthreads();
  if (threadIdx.x == 0) {
    floor_level = median_of_histogram(histogram, pixels);
    floors[b] = static_cast<std::uint8_t>(floor_level);
  }
  __syncthreads();
  for (std::uint32_t a = threadIdx.x; a < ascans; a += blockDim.x) {
    const ColumnFinding c =
        classify_column(bscan + std::size_t{a} * params.depth, params, floor_level);
    kinds[std::size_t{b} * ascans + a] = static_cast<std::uint8_t>(c.kind);
    reflexes[std::size_t{b} * ascans + a] = c.reflex_px;
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
                                      InstrumentFindings& findings) {
  const VolumeDims& dims = volume.dims();
  const std::size_t ascans = dims.ascans;
  const std::size_t columns = std::size_t{group.count} * ascans;
  kinds_.resize(columns);
  reflexes_.resize(columns);
  floors_.resize(group.count);
  if (host_kinds_.size() < columns) host_kinds_ = cuda::PinnedArray<std::uint8_t>(columns);
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
  classify_bscans<<<group.count, kThreads, 0, stream>>>(
      group_pixels, static_cast<std::uint32_t>(ascans), params, kinds_.data(), reflexes_.data(),
      floors_.data());
  cuda::check_launch("instruments: classify_bscans");
  const std::size_t offset = std::size_t{group.first} * ascans;
  cuda::copy_async(host_kinds_.data(), kinds_.data(), columns, cudaMemcpyDeviceToHost, stream,
                   cuda::Payload::other, "instruments: the A-scans' kinds to the host");
  cuda::copy_async(findings.reflex_px.data() + offset, reflexes_.data(), reflexes_.bytes(),
                   cudaMemcpyDeviceToHost, stream, cuda::Payload::other,
                   "instruments: the reflexes to the host");
  cuda::copy_async(findings.floor.data() + group.first, floors_.data(), group.count,
                   cudaMemcpyDeviceToHost, stream, cuda::Payload::other,
                   "instruments: the floors to the host");
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  for (std::size_t i = 0; i < columns; ++i) {
    findings.columns[offset + i] = static_cast<ColumnKind>(host_kinds_.data()[i]);
  }
}

}  // namespace ioct::gpu::instruments
