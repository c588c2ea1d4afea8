// The live stages on the device (CUDA builds, CUDA stages): where the live volume's bytes live
// while VolumeStages works on them.
//
// Hand-over (the live loop's thread): the new B-scans are copied device to device from the live
// volume (LiveVolumeSource::read_on_device) into a pending device volume on a copy stream of
// their own, which waits only for the last pass to have taken its input, so the processing never
// waits for a pass. A source with a host volume instead fills VolumeStages' host pending volume,
// and the pass uploads it (the stages' host path).
//
// Pass (the stages' thread): the pending B-scans are copied into the input volume, then the
// filter and the segmentation are enqueued on the pass stream, and the renderer's update and
// frame on the render stream: the texture, bricks and sums of the filtered B-scans while the
// segmentation runs (its searches leave most of the GPU idle), the layer reference and the frame
// once the surfaces are made. Each works on the previous one's device output, with no copy of the
// volume to the host and no wait for the host in between (the renderer makes its layer reference
// on the device too); the pass ends by waiting for its frame (and for the host's work done while
// the device renders: with instrument detection, the tips). Only what is asked for (a frame to
// write, the files at the end; with instrument detection the surfaces, the A-scans' classes and the
// tip's B-scan pair) comes back.
//
// In a mode rendered from Weiss's per-B-scan median (render_filter.hpp) the renderer's update reads
// a second device volume instead of the filtered one: the render stream waits for the pass's
// input, runs the per-B-scan median of the new B-scans into it (one kernel, while the pass stream
// runs the segmentation) and the update reads it there. A change of mode re-filters the whole
// input on the render stream (use_render_volume), with no pass and no host wait.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>

#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/render/render_config.hpp"
#include "ioct/gpu/render/rgba_image.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::filters {
class VolumeFilter;
}
namespace ioct::gpu::segmentation {
class Segmenter;
}
namespace ioct::gpu::render {
class Renderer;
}
namespace ioct::gpu::instruments {
class InstrumentDetector;
}

namespace ioct::gpu::live {

class DeviceStageChain {
 public:
  // Device time of each stage of a pass, ms, and when the pass was done (CLOCK_MONOTONIC: the
  // frame on the host when one was asked for, and while_the_pass_runs' work). The render's is
  // from the segmentation's end to the frame in device memory, or on the host when one was asked
  // for: the renderer's volume update overlaps the segmentation and is not in it.
  struct PassTimes {
    double filter_ms = 0.0, segment_ms = 0.0, render_ms = 0.0;
    std::uint64_t filtered_ns = 0, segmented_ns = 0, rendered_ns = 0;
    // The B-scans whose filtered pixels or surfaces the pass changed: the segmentation's
    // affected B-scans, which contain the filter's outputs.
    std::uint32_t changed_first = 0, changed_count = 0;
  };

  // Null when the stages are not all CUDA ones (or the build has no CUDA): they then work on
  // host volumes. Moves the renderer onto the chain's render stream. `render_filter` (the
  // renderer's own per-B-scan median; null: the renderer always reads `filter`'s volume) and
  // `detector` (none: null) must be CUDA ones too: they read the chain's input in place.
  static std::unique_ptr<DeviceStageChain> make(filters::VolumeFilter& filter,
                                                filters::VolumeFilter* render_filter,
                                                segmentation::Segmenter& segmenter,
                                                render::Renderer& renderer,
                                                const instruments::InstrumentDetector* detector);
  ~DeviceStageChain();
  DeviceStageChain(const DeviceStageChain&) = delete;
  DeviceStageChain& operator=(const DeviceStageChain&) = delete;

  // Live loop's thread, under the stages' lock. Enqueues the copy of B-scans [first, first +
  // count) of the source's device volume into the pending device volume. `new_shape` says when
  // `shape` differs from the passes' input: the pending volume is then zeroed first (otherwise a
  // new pending volume starts as the input, which take_host() filled). False, with nothing done,
  // for a host source.
  bool hand_over(LiveVolumeSource& source, const LiveVolumeShape& shape, std::uint32_t first,
                 std::uint32_t count, bool& new_shape);

  // Stages' thread, under the stages' lock: the pending B-scans [first, first + count) become
  // the pass's input, from the pending device volume, or (take_host) uploaded from a host one.
  // Returns the B-scans the pass must work on: these, or all when the input was new (other
  // dimensions).
  struct Taken {
    std::uint32_t first = 0, count = 0;
  };
  Taken take(std::uint32_t first, std::uint32_t count);
  Taken take_host(const Volume& pending, std::uint32_t first, std::uint32_t count);

  // Stages' thread: filter -> segment -> render the input's B-scans [first, first + count) (as
  // take() returned them), the renderer's volume the one view.mode renders from; the frame comes
  // back into `frame` only when one is given. `while_the_pass_runs` (when given) runs on the host
  // once the whole pass is enqueued (filter, segmentation, render), before the pass waits for it:
  // host work beside the device's (the instrument's tips) done while it filters, segments, renders
  // and the frame comes back. It may call download_surfaces(), which waits for the segmentation.
  // rendered_ns is then when both the frame and that work were done.
  PassTimes run_pass(std::uint32_t first, std::uint32_t count, const render::RenderConfig& view,
                     render::RgbaImage* frame,
                     const std::function<void()>& while_the_pass_runs = {});

  // Stages' thread, before a render in `mode` between passes: when `mode` renders from another
  // volume than the renderer holds, the whole input is filtered for it (or the filtered volume
  // taken) and the renderer updated, enqueued on the render stream (the render waits for it).
  // Nothing before the first pass.
  void use_render_volume(render::RenderMode mode);

  // The filtered volume and the surfaces, to the host (the files at the end).
  void download(Volume& filtered, segmentation::Surfaces& surfaces);
  // The B-scan a frame shows beside the render: B-scan `bscan` of the filtered volume with the
  // last pass's surfaces drawn over it (segmentation::make_overlay's picture), drawn on the
  // device, so that only the picture comes to the host. Returns once it is in `image`.
  void bscan_overlay(std::uint32_t bscan, segmentation::RgbImage& image);
  // The surfaces alone, to the host (the instrument's distances, while the pass renders). Called
  // with the same host copy pass after pass, it brings back only the B-scans the passes changed
  // since the last call (a group's B-scans and those its results reach, not the volume's); any
  // other copy, or one of other dimensions, gets every B-scan.
  void download_surfaces(segmentation::Surfaces& surfaces);
  // The passes' input (the unfiltered B-scans) as a device ref on the chain's stream: what the
  // instrument detection and the tip's B-scan pair read. Valid until the next take().
  VolumeRef input() const;
  // B-scans in the passes' input (0 before the first pass).
  std::uint32_t bscans() const noexcept;

 private:
  struct Impl;
  explicit DeviceStageChain(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace ioct::gpu::live
