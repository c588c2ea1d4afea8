#include "ioct/gpu/segmentation/cuda_overlay_image.hpp"

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"

namespace ioct::gpu::segmentation {
namespace {

// One thread per pixel, A-scans across: the image's rows are written whole by a warp; the
// B-scan's voxels are read down its A-scans, from the cache.
__global__ void overlay_kernel(const std::uint8_t* __restrict__ bscan_voxels, std::uint32_t ascans,
                               std::uint32_t depth, const float* ilm, const float* rpe,
                               const float* bm, const SurfaceState* state,
                               std::uint8_t* __restrict__ rgb) {
  const std::uint32_t a = blockIdx.x * blockDim.x + threadIdx.x;
  const std::uint32_t d = blockIdx.y * blockDim.y + threadIdx.y;
  if (a >= ascans || d >= depth) return;
  const std::uint8_t grey = __ldg(bscan_voxels + std::size_t{a} * depth + d);
  OverlayColor c{grey, grey, grey};
  if (overlay_column_marked(state[a], a)) {
    // make_overlay's order: where two lines meet, the later one shows.
    if (overlay_row(bm[a], depth) == static_cast<long>(d)) c = kBmColor;
    if (overlay_row(rpe[a], depth) == static_cast<long>(d)) c = kRpeColor;
    if (overlay_row(ilm[a], depth) == static_cast<long>(d)) c = kIlmColor;
  }
  std::uint8_t* out = rgb + (std::size_t{d} * ascans + a) * 3;
  out[0] = c.r;
  out[1] = c.g;
  out[2] = c.b;
}

}  // namespace

void make_overlay_on_device(const std::uint8_t* volume, const VolumeDims& dims, std::uint32_t bscan,
                            const DeviceSurfaceView& surfaces, std::uint8_t* rgb,
                            cudaStream_t stream) {
  check_overlay(dims, bscan, surfaces.bscans, surfaces.ascans);
  if (dims.ascans == 0 || dims.depth == 0) return;
  const std::size_t first = std::size_t{bscan} * dims.ascans;
  const dim3 block(32, 8);
  const dim3 grid((dims.ascans + block.x - 1) / block.x, (dims.depth + block.y - 1) / block.y);
  overlay_kernel<<<grid, block, 0, stream>>>(volume + bscan * dims.bscan_bytes(), dims.ascans,
                                             dims.depth, surfaces.ilm + first, surfaces.rpe + first,
                                             surfaces.bm + first, surfaces.state + first, rgb);
  IOCT_CUDA_CHECK(cudaGetLastError());
}

}  // namespace ioct::gpu::segmentation
