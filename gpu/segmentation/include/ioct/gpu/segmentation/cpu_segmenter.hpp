// The CPU implementation of the segmentation: the reference the CUDA one is tested against, and
// the segmenter of machines without a GPU. B-scans are spread over a WorkerPool, one per task.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/segmentation/column_math.hpp"
#include "ioct/gpu/segmentation/lifted_rpe.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/gpu/segmentation/volume_memory.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu::segmentation {

class CpuSegmenter final : public Segmenter {
 public:
  // Validates the config and sampling (ConfigError); threads >= 1, the caller included.
  CpuSegmenter(const SegmentationConfig& config, const VolumeSampling& sampling,
               unsigned threads = 1);

  using Segmenter::segment_group;
  BscanSpan segment_group(const Volume& volume, BscanSpan group, Surfaces& surfaces) override;
  void forget() override { memory_ = {}; }
  const SegmentationConfig& config() const noexcept override { return config_; }
  const VolumeSampling& sampling() const noexcept override { return sampling_; }
  std::string_view backend_name() const noexcept override { return "cpu"; }

  // What the segmenter remembers of the volume (tests compare it between backends).
  const VolumeMemory& memory() const noexcept { return memory_; }

 private:
  // Scratch of one thread: the costs and path totals of one B-scan's searches.
  struct Workspace {
    std::vector<std::uint8_t> levels;   // [ascan][cell]
    std::vector<std::int32_t> cost;     // [ascan][state]
    std::vector<std::int32_t> origin;   // [ascan]
    std::vector<std::int32_t> forward;  // one row of totals
    std::vector<std::int32_t> backward;
    std::vector<std::int32_t> next;
    std::vector<std::int8_t> steps;       // [ascan][state]
    std::vector<std::int32_t> path;       // [ascan]
    std::vector<std::int32_t> ilm_px;     // [ascan]
    std::vector<detail::ColumnFit> fits;  // [ascan]
    std::vector<float> smoothed_bm;       // [ascan] (lifted_rpe.hpp)
    std::vector<float> bm_floor;          // [ascan]
    std::vector<float> next_floor;        // [ascan]
  };

  void coarse_bscan(const Volume& volume, std::uint32_t bscan, Workspace& w);
  void fine_bscan(const Volume& volume, std::uint32_t bscan, Workspace& w);
  // Bruch's membrane of a finished B-scan into `bm`, from its finished BM (lifted_rpe.hpp).
  void membrane_bscan(const float* finished_bm, const detail::MembraneSettings& settings, float* bm,
                      Workspace& w) const;

  SegmentationConfig config_;
  VolumeSampling sampling_;
  WorkerPool pool_;
  std::vector<Workspace> workspaces_;
  SegmentationParams params_;
  VolumeMemory memory_;
  std::vector<std::uint8_t> measured_;  // [bscan][ascan] (finishing.hpp, RawFits::measured)
};

// The search along one B-scan, exposed for tests: the least-cost path through `ascans` columns
// of `states` states each, state s of column a lying at depth origin[a] + s, a step of j px
// between neighbouring columns allowed for |j| <= max_step at a cost of penalty * |j|. Computed
// from both ends and joined at column ascans / 2; writes the path's depths to `path`.
void solve_path(std::int32_t ascans, std::int32_t states, const std::int32_t* origin,
                const std::int32_t* cost, std::int32_t max_step, std::int32_t penalty,
                std::int32_t* path, std::vector<std::int32_t>& forward,
                std::vector<std::int32_t>& backward, std::vector<std::int32_t>& next,
                std::vector<std::int8_t>& steps);

}  // namespace ioct::gpu::segmentation
