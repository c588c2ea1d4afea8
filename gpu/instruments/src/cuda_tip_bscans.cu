#include "cuda_tip_bscans.hpp"

#include <cstring>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"

namespace ioct::gpu::instruments {
namespace {

// One thread per px of the pair, a column's threads side by side along the depth.
__global__ void cut_pair(const std::uint8_t* volume, std::uint32_t bscans, std::uint32_t ascans,
                         std::uint32_t depth, TipCut cut, std::uint8_t* out) {
  const std::uint32_t d = blockIdx.x * blockDim.x + threadIdx.x;
  const std::uint32_t c = blockIdx.y;
  if (d >= depth) return;
  const TipColumn col = tip_column(cut, c, bscans, ascans, depth);
  out[std::size_t{d} * 2 * cut.width + c] = tip_pixel(col, volume, d);
}

}  // namespace

void cut_tip_bscans_on_device(const VolumeRef& volume, const TipCut& cut, TipBscans& out) {
  const VolumeDims& dims = volume.dims();
  cudaStream_t stream = volume.stream();
  // Kept per thread (the stages' thread cuts once per pass): no allocation, no implicit
  // synchronisation of the device, after the first cut.
  thread_local cuda::DeviceArray<std::uint8_t> pair;
  thread_local cuda::PinnedDownload download;
  pair.resize(out.pixels.size());
  constexpr unsigned kThreads = 128;
  const dim3 grid((dims.depth + kThreads - 1) / kThreads, out.stride());
  cut_pair<<<grid, kThreads, 0, stream>>>(volume.device(), dims.bscans, dims.ascans, dims.depth,
                                          cut, pair.data());
  cuda::check_launch("instruments: cut_pair");
  download.add(pair.data(), out.pixels.size());
  download.fetch(stream, cuda::Payload::other, "instruments: the tip's B-scan pair to the host");
  std::memcpy(out.pixels.data(), download.piece(0).data(), out.pixels.size());
}

}  // namespace ioct::gpu::instruments
