#include "ioct/gpu/segmentation/segmenter.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "ioct/gpu/segmentation/cpu_segmenter.hpp"
#if IOCT_SEGMENTATION_HAVE_CUDA
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#include "ioct/gpu/segmentation/finishing.hpp"
#endif

namespace ioct::gpu::segmentation {

void Segmenter::segment_volume(const Volume& volume, Surfaces& surfaces) {
  forget();
  if (volume.bscans() == 0) {
    surfaces.reset(0, volume.ascans(), volume.depth());
    return;
  }
  segment_group(volume, {0, volume.bscans()}, surfaces);
}

BscanSpan Segmenter::outputs_affected(BscanSpan group, std::uint32_t bscans) const {
  // Bridges reach bridge_bscans B-scans, and whether a fit there counts as measured depends on
  // the fits kAcrossCheckBscans beyond it.
  const std::uint32_t reach = std::max<std::uint32_t>(1, config().bridge_bscans) +
                              static_cast<std::uint32_t>(detail::kAcrossCheckBscans);
  const std::uint32_t first = group.first > reach ? group.first - reach : 0;
  const auto end = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(std::uint64_t{group.end()} + reach, bscans));
  return {first, end - first};
}

BscanSpan Segmenter::segment_group(VolumeRef volume, BscanSpan group, Surfaces* surfaces) {
  if (volume.is_device()) {
    throw std::invalid_argument("segmentation (" + std::string(backend_name()) +
                                "): takes host volumes only; device volumes need the cuda backend");
  }
  if (surfaces == nullptr) {
    throw std::invalid_argument("segmentation: a host volume needs surfaces to write into");
  }
  return segment_group(volume.host(), group, *surfaces);
}

void check_group_request(const Volume& volume, BscanSpan group) {
  check_group_request(VolumeDims::of(volume), group);
}

void check_group_request(VolumeDims volume, BscanSpan group) {
  const auto dims = [&] {
    return std::to_string(volume.bscans) + " x " + std::to_string(volume.ascans) + " x " +
           std::to_string(volume.depth);
  };
  if (volume.ascans == 0 || volume.depth < kMinDepth || volume.depth > kMaxDepth ||
      volume.ascans > kMaxAscans) {
    throw std::invalid_argument("segmentation: a volume of " + dims() +
                                " (B-scans x A-scans x depth px) cannot be segmented: A-scans "
                                "must be in [1, " +
                                std::to_string(kMaxAscans) + "], depth in [" +
                                std::to_string(kMinDepth) + ", " + std::to_string(kMaxDepth) +
                                "] px");
  }
  if (group.count == 0 || group.first >= volume.bscans ||
      group.count > volume.bscans - group.first) {
    throw std::out_of_range("segmentation: B-scans [" + std::to_string(group.first) + ", " +
                            std::to_string(std::uint64_t{group.first} + group.count) +
                            ") are not a group of the volume of " + std::to_string(volume.bscans) +
                            " B-scans");
  }
}

std::unique_ptr<Segmenter> make_segmenter(Backend backend, const SegmentationConfig& config,
                                          const VolumeSampling& sampling, unsigned cpu_threads) {
  config.validate();
  sampling.validate();
  if (backend == Backend::cpu) return std::make_unique<CpuSegmenter>(config, sampling, cpu_threads);
#if IOCT_SEGMENTATION_HAVE_CUDA
  if (backend == Backend::cuda) return std::make_unique<CudaSegmenter>(config, sampling);
  try {
    return std::make_unique<CudaSegmenter>(config, sampling);
  } catch (const BackendUnavailable&) {
    return std::make_unique<CpuSegmenter>(config, sampling, cpu_threads);
  }
#else
  if (backend == Backend::cuda) {
    throw BackendUnavailable(
        "backend cuda: this build has no CUDA segmentation; use the cpu backend");
  }
  return std::make_unique<CpuSegmenter>(config, sampling, cpu_threads);
#endif
}

}  // namespace ioct::gpu::segmentation
