#include "ioct/gpu/render/cpu_renderer.hpp"
#include "ioct/gpu/render/renderer.hpp"

#if IOCT_RENDER_HAVE_CUDA
#include "ioct/gpu/render/cuda_renderer.hpp"
#endif

namespace ioct::gpu::render {

std::unique_ptr<Renderer> make_renderer(Backend backend, unsigned cpu_threads) {
  if (backend == Backend::cpu) return std::make_unique<CpuRenderer>(cpu_threads);
  const auto problem = cuda_unavailable_reason();
  if (problem) {
    if (backend == Backend::cuda) throw BackendUnavailable("cuda renderer: " + *problem);
    return std::make_unique<CpuRenderer>(cpu_threads);
  }
#if IOCT_RENDER_HAVE_CUDA
  return std::make_unique<CudaRenderer>();
#else
  if (backend == Backend::cuda) throw BackendUnavailable("cuda renderer: built without CUDA");
  return std::make_unique<CpuRenderer>(cpu_threads);
#endif
}

}  // namespace ioct::gpu::render
