#include "ioct/gpu/filters/volume_filter.hpp"

#include <stdexcept>
#include <string>

#include "ioct/gpu/filters/cpu_volume_filter.hpp"
#if IOCT_FILTERS_HAVE_CUDA
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#endif

namespace ioct::gpu::filters {

std::unique_ptr<VolumeFilter> make_volume_filter(Backend backend, const VolumeFilterConfig& config,
                                                 unsigned cpu_threads) {
  config.validate();
  if (backend == Backend::cpu) return std::make_unique<CpuVolumeFilter>(config, cpu_threads);
#if IOCT_FILTERS_HAVE_CUDA
  if (backend == Backend::cuda) return std::make_unique<CudaVolumeFilter>(config);
  // Any other request (automatic): the GPU when one is usable, else the CPU.
  try {
    return std::make_unique<CudaVolumeFilter>(config);
  } catch (const BackendUnavailable&) {
    return std::make_unique<CpuVolumeFilter>(config, cpu_threads);
  }
#else
  if (backend == Backend::cuda) {
    throw BackendUnavailable("backend cuda: this build has no CUDA filters; use the cpu backend");
  }
  return std::make_unique<CpuVolumeFilter>(config, cpu_threads);
#endif
}

BscanRange VolumeFilter::filter_group(VolumeRef in, MutableVolumeRef out, BscanRange changed) {
  if (in.is_device() || out.is_device()) {
    throw std::invalid_argument("volume filter (" + std::string(backend_name()) +
                                "): takes host volumes only; device volumes need the cuda backend");
  }
  return filter_group(in.host(), out.host(), changed.first, changed.count);
}

BscanRange check_group_request(const Volume& in, const Volume& out, std::uint32_t first_bscan,
                               std::uint32_t count) {
  if (&in == &out) throw std::invalid_argument("volume filter: input and output are one volume");
  if (in.bscans() != out.bscans() || in.ascans() != out.ascans() || in.depth() != out.depth()) {
    const auto dims = [](const Volume& v) {
      return std::to_string(v.bscans()) + " x " + std::to_string(v.ascans()) + " x " +
             std::to_string(v.depth());
    };
    throw std::invalid_argument("volume filter: output of " + dims(out) +
                                " pixels does not match the input of " + dims(in));
  }
  return outputs_affected_by({first_bscan, count}, in.bscans());
}

}  // namespace ioct::gpu::filters
