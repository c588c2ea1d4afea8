#include "ioct/gpu/processing/oct_processor.hpp"

#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/processing/cuda_oct_processor.hpp"
#endif

namespace ioct::gpu {

void OctProcessorConfig::validate() const {
  background.validate();
  resampling.validate();
  window.validate();
  dispersion.validate();
  fft.validate();
  scale.validate();
  require_integer_in_range("repeats_per_position", repeats_per_position, 1, 16);
  require_integer_in_range("threads", threads, 1, 16);
}

void OctProcessorConfig::validate_for(const shm::RingGeometry& geometry) const {
  validate();
  resampling.validate_for(geometry.samples_per_ascan);
  const std::uint32_t r = repeats_per_position;
  if (geometry.bscans_per_group % r != 0 || geometry.bscans_per_volume % r != 0) {
    throw ConfigError("repeats_per_position", format_value(std::uint64_t{r}),
                      "must divide the ring's bscans_per_group (" +
                          std::to_string(geometry.bscans_per_group) + ") and bscans_per_volume (" +
                          std::to_string(geometry.bscans_per_volume) + ")");
  }
}

std::unique_ptr<OctProcessor> make_oct_processor(Backend backend,
                                                 const OctProcessorConfig& config) {
  config.validate();
  switch (resolve_backend(backend)) {
    case Backend::cpu:
      return std::make_unique<CpuOctProcessor>(config);
    case Backend::cuda:
#if IOCT_GPU_WITH_CUDA
      return std::make_unique<CudaOctProcessor>(config);
#else
      throw BackendUnavailable(
          "backend cuda: this ioct-gpu was built without CUDA; use --backend cpu or auto");
#endif
    case Backend::automatic:
      break;
  }
  throw ConfigError("backend", std::to_string(static_cast<int>(backend)),
                    "must be cpu, cuda or auto");
}

}  // namespace ioct::gpu
