// Whether this build's kernels can run on the current device (cudaErrorNoKernelImageForDevice
// when the binary carries no code for its architecture).
#pragma once

#include <cuda_runtime_api.h>

namespace ioct::gpu::filters {

cudaError_t probe_filter_kernels();

}  // namespace ioct::gpu::filters
