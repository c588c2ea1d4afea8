// Whether the cuda backend can run on this machine, and the error texts of CUDA and cuFFT.
#include <mutex>
#include <optional>
#include <string>

#include "ioct/gpu/cuda/backend.hpp"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/device_memory.hpp"

#ifndef IOCT_CUDA_ARCHITECTURES
#define IOCT_CUDA_ARCHITECTURES "unknown"
#endif

namespace ioct::gpu {
namespace cuda {

std::string describe(cudaError_t status) {
  return std::string(cudaGetErrorName(status)) + " (" + cudaGetErrorString(status) + ")";
}

std::string describe(cufftResult status) {
  switch (status) {
    case CUFFT_INVALID_PLAN:
      return "CUFFT_INVALID_PLAN";
    case CUFFT_ALLOC_FAILED:
      return "CUFFT_ALLOC_FAILED (out of device memory)";
    case CUFFT_INVALID_VALUE:
      return "CUFFT_INVALID_VALUE";
    case CUFFT_INTERNAL_ERROR:
      return "CUFFT_INTERNAL_ERROR";
    case CUFFT_EXEC_FAILED:
      return "CUFFT_EXEC_FAILED";
    case CUFFT_SETUP_FAILED:
      return "CUFFT_SETUP_FAILED";
    case CUFFT_INVALID_SIZE:
      return "CUFFT_INVALID_SIZE";
    default:
      return "cuFFT error " + std::to_string(static_cast<int>(status));
  }
}

}  // namespace cuda

namespace {

// A kernel of this library, to ask the runtime whether the binary has code for the device (the
// stages' kernels are built for the same CMAKE_CUDA_ARCHITECTURES).
__global__ void probe() {}

std::optional<std::string> find_device_problem() {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    cudaGetLastError();
    return "no CUDA device: cudaGetDeviceCount failed: " + cuda::describe(status) +
           " (no NVIDIA GPU or driver on this machine)";
  }
  if (count == 0) return std::string("no CUDA device: the driver reports 0 GPUs");
  int device = 0;
  if (cudaGetDevice(&device) != cudaSuccess) device = 0;
  cudaDeviceProp props{};
  if (const cudaError_t e = cudaGetDeviceProperties(&props, device); e != cudaSuccess) {
    return "CUDA device " + std::to_string(device) + " unusable: " + cuda::describe(e);
  }
  // The kernels only run if the binary carries code (SASS or PTX) this GPU can use.
  cudaFuncAttributes attributes{};
  if (const cudaError_t e =
          cudaFuncGetAttributes(&attributes, reinterpret_cast<const void*>(&probe));
      e != cudaSuccess) {
    cudaGetLastError();
    const std::string cc = std::to_string(props.major) + "." + std::to_string(props.minor);
    return "GPU " + std::to_string(device) + " (" + props.name + ", compute capability " + cc +
           ") is not supported by this build: it carries code for CUDA architectures " +
           IOCT_CUDA_ARCHITECTURES + " only (" + cuda::describe(e) +
           "); rebuild with -DCMAKE_CUDA_ARCHITECTURES=" + std::to_string(props.major) +
           std::to_string(props.minor);
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> cuda_device_problem() {
  // Asked once: the first CUDA call initialises the driver, which takes a while.
  static std::once_flag once;
  static std::optional<std::string> problem;
  std::call_once(once, [] { problem = find_device_problem(); });
  return problem;
}

std::optional<DeviceMemory> device_memory() noexcept {
  std::size_t free_bytes = 0;
  std::size_t total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) != cudaSuccess) {
    cudaGetLastError();  // not sticky: clear it for the next call
    return std::nullopt;
  }
  return DeviceMemory{total_bytes - free_bytes, total_bytes};
}

}  // namespace ioct::gpu
