// make_overlay's CUDA sibling: the B-scan shown with its surfaces, drawn on the device from the
// device volume and the CUDA segmenter's device surfaces, so that a live frame's B-scan comes to
// the host as one picture instead of its voxels and the whole volume's surfaces. The same pixels
// as make_overlay (overlay_image.hpp holds the rules both follow).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::segmentation {

// Enqueues on `stream` the overlay of B-scan `bscan` of `volume` (device memory,
// [bscan][ascan][depth] of `dims`) with `surfaces` (of the same bscans and ascans) into `rgb`
// (device memory, dims.depth rows of dims.ascans x 3 bytes). Throws std::out_of_range for a
// B-scan outside the volume and std::invalid_argument for surfaces of other dimensions, as
// make_overlay does; CudaError for a failed launch.
void make_overlay_on_device(const std::uint8_t* volume, const VolumeDims& dims, std::uint32_t bscan,
                            const DeviceSurfaceView& surfaces, std::uint8_t* rgb,
                            cudaStream_t stream);

}  // namespace ioct::gpu::segmentation
