#include "ioct/gpu/ingest/live_pipeline.hpp"

#include <stdexcept>
#include <string>

#include "ioct/gpu/ingest/host_live_pipeline.hpp"
#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/ingest/cuda_live_pipeline.hpp"
#endif

namespace ioct::gpu {

void prepare_bscan_copy(const LiveVolumeShape& shape, std::uint32_t first, std::uint32_t count,
                        Volume& out) {
  if (count != 0 && (first >= shape.bscans || count > shape.bscans - first)) {
    throw std::out_of_range("B-scans [" + std::to_string(first) + ", " +
                            std::to_string(std::uint64_t{first} + count) +
                            ") outside the live volume's " + std::to_string(shape.bscans));
  }
  out.reshape(shape.bscans, shape.ascans, shape.depth);  // (keeps the memory when it fits)
}

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
