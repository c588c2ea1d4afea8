#include <stdexcept>
#include <string>

#include "ioct/gpu/render/cpu_renderer.hpp"
#include "ioct/gpu/render/renderer.hpp"

#if IOCT_RENDER_HAVE_CUDA
#include "ioct/gpu/render/cuda_renderer.hpp"
#endif

namespace ioct::gpu::render {

void check_bscan_range(std::uint32_t bscans, std::uint32_t first, std::uint32_t count) {
  if (count == 0 || first >= bscans || count > bscans - first) {
    throw std::out_of_range("B-scans [" + std::to_string(first) + ", " +
                            std::to_string(std::uint64_t{first} + count) +
                            ") outside the volume's " + std::to_string(bscans));
  }
}

void Renderer::update_bscans(VolumeRef volume, std::uint32_t first, std::uint32_t count,
                             const segmentation::Surfaces* surfaces) {
  if (volume.is_device()) {
    throw std::invalid_argument("renderer (" + std::string(backend_name()) +
                                "): takes host volumes only; device volumes need the cuda backend");
  }
  update_bscans(volume.host(), first, count, surfaces);
}

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
