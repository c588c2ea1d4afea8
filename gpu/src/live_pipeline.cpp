#include "ioct/gpu/live_pipeline.hpp"

#include "ioct/gpu/host_live_pipeline.hpp"
#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/cuda_live_pipeline.hpp"
#endif

namespace ioct::gpu {

std::unique_ptr<LivePipeline> make_live_pipeline(Backend backend, const OctProcessorConfig& config,
                                                 shm::RingReader reader,
                                                 const LivePipelineOptions& options) {
  const Backend resolved = resolve_backend(backend);
#if IOCT_GPU_WITH_CUDA
  if (resolved == Backend::cuda) {
    return std::make_unique<CudaLivePipeline>(config, std::move(reader), options);
  }
#else
  (void)options;
#endif
  return std::make_unique<HostLivePipeline>(make_oct_processor(resolved, config),
                                            config.repeats_per_position, std::move(reader));
}

}  // namespace ioct::gpu
