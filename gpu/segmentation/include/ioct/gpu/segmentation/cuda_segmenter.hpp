// The CUDA implementation of the segmentation (built only with CUDA): the same stages as
// CpuSegmenter on the same integer evidence (column_math.hpp) and the same finishing
// (finishing.hpp), so both give the same surfaces; tests compare them exactly.
//
// Per group, on one stream: the B-scans' histograms (background level), the coarse costs (one
// thread block per few pairs of A-scans, across the whole GPU), the coarse search (one block per
// B-scan: both halves of the B-scan at once, one thread per state, the step choices in shared
// memory, joined in the middle and traced back from there), the ILM band costs, the ILM search,
// the RPE band costs, the RPE search, the sub-px fits (remembering, in a B-scan's first search of
// a cycle, what they replace: finishing.hpp) with each B-scan's typical contrasts and verdict (one
// block per B-scan), the finishing of every affected A-scan, and Bruch's membrane beneath lifted
// RPE in each affected B-scan (lifted_rpe.hpp; one block per B-scan). The cycle clock lives on the
// device (advanced by the coarse costs' first block), so a captured graph needs no host input.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <memory>
#include <string>

#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/gpu/segmentation/volume_memory.hpp"

namespace ioct::gpu::segmentation {

// Where the surfaces of the volume live on the device, [bscan][ascan] (for renderers that read
// them there). Valid until the next call that changes the volume's dimensions.
struct DeviceSurfaceView {
  const float* ilm = nullptr;
  const float* rpe = nullptr;
  const float* bm = nullptr;
  const float* confidence = nullptr;
  const SurfaceState* state = nullptr;
  const BscanVerdict* verdict = nullptr;  // [bscan]
  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
};

class CudaSegmenter final : public Segmenter {
 public:
  // Validates the config and sampling (ConfigError). Throws BackendUnavailable when there is no
  // CUDA device (with CUDA's reason) or the device cannot run this build's code.
  CudaSegmenter(const SegmentationConfig& config, const VolumeSampling& sampling);
  ~CudaSegmenter() override;

  // Host volumes: the group's B-scans are copied to the device, segmented, and the affected
  // B-scans' surfaces copied back; returns when they are in `surfaces`.
  BscanSpan segment_group(const Volume& volume, BscanSpan group, Surfaces& surfaces) override;
  // Device refs: prepare() for their dimensions (after waiting for their stream when those
  // change), then enqueue_group() on their stream.
  BscanSpan segment_group(VolumeRef volume, BscanSpan group, Surfaces* surfaces) override;
  void forget() override;
  const SegmentationConfig& config() const noexcept override { return config_; }
  const VolumeSampling& sampling() const noexcept override { return sampling_; }
  std::string_view backend_name() const noexcept override { return "cuda"; }

  // The live case, the volume already on the device ([bscan][ascan][depth], depth contiguous,
  // no padding): prepares for its dimensions (forgetting an earlier volume of others), then
  // enqueues the segmentation of `group` on `stream` without synchronising. The surfaces are in
  // device_surfaces() once the stream reaches that point. Same exceptions as segment_group.
  void prepare(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth);
  BscanSpan enqueue_group(const std::uint8_t* device_volume, BscanSpan group, cudaStream_t stream);
  DeviceSurfaceView device_surfaces() const noexcept;
  // Copies every surface of the device into `surfaces` (sized to the volume's dimensions) once
  // `stream` has reached this point; returns when they are there.
  void download_surfaces(Surfaces& surfaces, cudaStream_t stream);
  // The same for B-scans `rows` only, into `surfaces` of the volume's dimensions (a host copy
  // kept up to date pass by pass: only what the passes changed comes back). Throws
  // std::invalid_argument for `surfaces` of other dimensions, std::out_of_range for rows past
  // the volume.
  void download_surfaces(Surfaces& surfaces, BscanSpan rows, cudaStream_t stream);

  // The intermediate results on the device, copied into `memory` (tests compare them with the
  // CPU's). Synchronises the segmenter's stream.
  void download_memory(VolumeMemory& memory);

  cudaStream_t stream() const noexcept { return stream_; }

  // enqueue_group launches each group (by volume, group and stream) as a CUDA graph captured on
  // first use, which takes out most of the launch overhead of its ten kernels; off: plain
  // launches on the stream (also for the legacy default stream, which cannot be captured).
  void set_use_graphs(bool use) noexcept { use_graphs_ = use; }

  // Benchmarks: when set, enqueue_group launches directly and records one event after each of
  // its kStages stages (coarse costs with the background histograms, coarse search with the
  // background level, ILM costs, ILM search, RPE costs, RPE search, the fits with the B-scans'
  // verdicts, finishing with Bruch's membrane) into these events.
  static constexpr int kStages = 8;
  void set_stage_events(const cudaEvent_t* events) noexcept { stage_events_ = events; }

 private:
  struct DeviceState;

  SegmentationConfig config_;
  VolumeSampling sampling_;
  cudaStream_t stream_ = nullptr;
  BscanSpan enqueue_direct(const std::uint8_t* device_volume, BscanSpan group, cudaStream_t stream);
  static void check_group_span(BscanSpan group, std::uint32_t bscans);

  std::unique_ptr<DeviceState> state_;
  // The memory's resets (prepare, forget) run on stream_; a group on a caller's stream waits for
  // them (segment_group), so it never runs before them.
  cudaEvent_t resets_done_ = nullptr;
  bool resets_pending_ = false;
  void note_resets();
  const cudaEvent_t* stage_events_ = nullptr;
  bool use_graphs_ = true;
};

// Why the CUDA segmentation cannot run here ("no CUDA device ...", "this build's kernels cannot
// run on device 0 ..."), or empty.
std::string cuda_segmentation_problem();

}  // namespace ioct::gpu::segmentation
