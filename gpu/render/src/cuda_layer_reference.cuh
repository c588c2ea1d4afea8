// The layer reference on the device (CUDA builds): what make_layer_reference() makes on the host
// (layer_reference.hpp), made where the centre-of-mass sums and the segmenter's surfaces already
// are, so that updating the renderer needs no round trip to the host. The same rules, the same
// float operations in the same order (the library builds without FMA): the RPE with its holes
// filled along each B-scan, B-scans without one taking the nearest B-scan's row, the axial plane
// at the centre of mass, and the mean thickness, which stays on the device for the kernels
// (RenderParams::measured_d_rpe_px).
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/render/layer_reference.hpp"

namespace ioct::gpu::render {

class DeviceLayerReference {
 public:
  // Sized for a volume's B-scans x A-scans; what was made before is lost.
  void resize(std::uint32_t bscans, std::uint32_t ascans);

  // Enqueues the reference's making on `stream`. `sums` holds the (weighted depth, weight) pair of
  // every B-scan (what the centre-of-mass kernel accumulates); `ilm` and `rpe` are device surfaces
  // of the same B-scans x A-scans, or both null when there are none usable.
  void make(const unsigned long long* sums, std::uint32_t depth, const float* ilm, const float* rpe,
            cudaStream_t stream);

  const float* rpe_px() const noexcept { return rpe_.data(); }
  const float* axial_plane_px() const noexcept { return axial_.data(); }
  // The mean retinal thickness in px, 0 when unknown (one float on the device).
  const float* mean_thickness_px() const noexcept { return scalars_.data(); }

  // The whole reference on the host (tests; waits for `stream`).
  LayerReference download(cudaStream_t stream) const;

 private:
  std::uint32_t bscans_ = 0, ascans_ = 0;
  cuda::DeviceArray<float> rpe_, axial_;
  // [0] mean thickness px, [1] centre of mass px, [2] 1 when some B-scan has an RPE value.
  cuda::DeviceArray<float> scalars_;
  // Per B-scan: 1 when its RPE has a value, the A-scans with both surfaces, their thickness.
  cuda::DeviceArray<std::uint32_t> has_row_, row_both_;
  cuda::DeviceArray<double> row_thickness_;
};

}  // namespace ioct::gpu::render
