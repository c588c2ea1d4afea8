// Without CUDA there is no device memory to report (the CUDA build's device_memory() lives in
// cuda_device.cu, beside the other driver queries).
#include "ioct/gpu/cuda/device_memory.hpp"

#if !IOCT_GPU_WITH_CUDA

namespace ioct::gpu {

std::optional<DeviceMemory> device_memory() noexcept {
  return std::nullopt;
}

}  // namespace ioct::gpu

#endif
