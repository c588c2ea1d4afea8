#include "device_stage_chain.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <utility>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/live_stages/render_filter.hpp"
#include "ioct/gpu/render/renderer.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

#if IOCT_GPU_WITH_CUDA && IOCT_FILTERS_HAVE_CUDA && IOCT_SEGMENTATION_HAVE_CUDA && \
    IOCT_RENDER_HAVE_CUDA
#define IOCT_LIVE_DEVICE_CHAIN 1
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#include "ioct/gpu/render/cuda_renderer.hpp"
#include "ioct/gpu/segmentation/cuda_overlay_image.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#else
#define IOCT_LIVE_DEVICE_CHAIN 0
#endif

namespace ioct::gpu::live {

#if IOCT_LIVE_DEVICE_CHAIN

namespace {

std::uint64_t ns_before(std::uint64_t end_ns, float ms) {
  const auto ns = static_cast<std::uint64_t>(static_cast<double>(ms) * 1e6);
  return end_ns > ns ? end_ns - ns : 0;
}

}  // namespace

struct DeviceStageChain::Impl {
  filters::CudaVolumeFilter& filter;
  filters::CudaVolumeFilter* bscan_filter;  // null: the renderer reads `filtered` in every mode
  segmentation::CudaSegmenter& segmenter;
  render::CudaRenderer& renderer;

  cuda::Stream stream;         // the passes: take, filter, segmentation
  cuda::Stream render_stream;  // the renderer's update and frames
  cuda::Stream copy_stream;    // the hand-overs
  cuda::Event pending_ready;
  cuda::Event input_taken;
  bool input_taken_recorded = false;
  cuda::TimingEvent started, filtered_done, segmented_done, rendered_done, frame_copied, pass_done;

  VolumeDims pending_dims, input_dims;
  cuda::DeviceArray<std::uint8_t> pending, input, filtered;
  // bscan_filter's output, the renderer's volume in the modes that render from it; allocated at
  // the first such mode and kept (a change of mode then costs no allocation).
  cuda::DeviceArray<std::uint8_t> render_filtered;
  bool renderer_bscan_median = false;  // the renderer holds render_filtered's B-scans
  cuda::Event render_input_read;       // the render stream's last read of the input
  bool render_input_read_recorded = false;
  // The B-scan shown, drawn with its surfaces (bscan_overlay), and its way to the host.
  cuda::DeviceArray<std::uint8_t> overlay;
  cuda::PinnedDownload overlay_download;
  // The host copy of the surfaces download_surfaces keeps up to date, and the B-scans
  // [unsynced_first, unsynced_end) whose surfaces the passes changed since (all before the first
  // download; empty when first >= end).
  const segmentation::Surfaces* synced_surfaces = nullptr;
  std::uint32_t unsynced_first = 0;
  std::uint32_t unsynced_end = UINT32_MAX;

  Impl(filters::CudaVolumeFilter& f, filters::CudaVolumeFilter* bscan,
       segmentation::CudaSegmenter& s, render::CudaRenderer& r)
      : filter(f), bscan_filter(bscan), segmenter(s), renderer(r) {
    renderer.use_stream(render_stream.get());
  }

  bool wants_bscan_median(render::RenderMode mode) const {
    return bscan_filter != nullptr && renders_from_bscan_median(mode);
  }

  // The input (and the filtered volume) take the pending volume's dimensions: true when they
  // had others. Nothing may still read them.
  bool reshape_input() {
    if (input_dims == pending_dims && input.size() == pending_dims.bytes()) return false;
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream.get()));
    IOCT_CUDA_CHECK(cudaStreamSynchronize(render_stream.get()));  // its median reads the input
    input = {};
    filtered = {};
    input = cuda::DeviceArray<std::uint8_t>(pending_dims.bytes());
    filtered = cuda::DeviceArray<std::uint8_t>(pending_dims.bytes());
    input_dims = pending_dims;
    return true;
  }

  // Before a take overwrites the input: the render stream's median must have read it.
  void wait_for_render_reads() {
    if (render_input_read_recorded) {
      IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream.get(), render_input_read.get(), 0));
    }
  }

  void record_taken() {
    IOCT_CUDA_CHECK(cudaEventRecord(input_taken.get(), stream.get()));
    input_taken_recorded = true;
  }

  // The renderer's volume update, enqueued on the render stream: from the filtered volume (its
  // B-scans `outputs` new), or with `bscan_median` from the per-B-scan median of the input (its
  // B-scans `changed` new), filtered here on the render stream once the pass stream took the input.
  // A change between the two takes all B-scans. The caller makes the layer reference after it.
  void update_render_volume(bool bscan_median, filters::BscanRange changed,
                            filters::BscanRange outputs) {
    const VolumeDims dims = input_dims;
    cudaStream_t rs = render_stream.get();
    const filters::BscanRange all{0, dims.bscans};
    if (!bscan_median) {
      const filters::BscanRange update = renderer_bscan_median ? all : outputs;
      renderer.update_volume(VolumeRef::on_device(filtered.data(), dims, stream.get()),
                             update.first, update.count);
      renderer_bscan_median = false;
      return;
    }
    bool whole = !renderer_bscan_median;
    if (render_filtered.size() != dims.bytes()) {
      IOCT_CUDA_CHECK(cudaStreamSynchronize(rs));  // a new geometry: nothing may still read it
      render_filtered = {};
      render_filtered = cuda::DeviceArray<std::uint8_t>(dims.bytes());
      whole = true;
    }
    IOCT_CUDA_CHECK(cudaStreamWaitEvent(rs, input_taken.get(), 0));
    const filters::BscanRange median_outputs = bscan_filter->filter_group(
        VolumeRef::on_device(input.data(), dims, rs),
        MutableVolumeRef::on_device(render_filtered.data(), dims, rs), whole ? all : changed);
    IOCT_CUDA_CHECK(cudaEventRecord(render_input_read.get(), rs));
    render_input_read_recorded = true;
    const filters::BscanRange update = whole ? all : median_outputs;
    renderer.update_volume(VolumeRef::on_device(render_filtered.data(), dims, rs), update.first,
                           update.count);
    renderer_bscan_median = true;
  }
};

std::unique_ptr<DeviceStageChain> DeviceStageChain::make(
    filters::VolumeFilter& filter, filters::VolumeFilter* render_filter,
    segmentation::Segmenter& segmenter, render::Renderer& renderer,
    const instruments::InstrumentDetector* detector) {
  auto* f = dynamic_cast<filters::CudaVolumeFilter*>(&filter);
  auto* b = dynamic_cast<filters::CudaVolumeFilter*>(render_filter);
  auto* s = dynamic_cast<segmentation::CudaSegmenter*>(&segmenter);
  auto* r = dynamic_cast<render::CudaRenderer*>(&renderer);
  if (f == nullptr || s == nullptr || r == nullptr) return nullptr;
  if (render_filter != nullptr && b == nullptr) return nullptr;
  if (detector != nullptr && detector->backend_name() != "cuda") return nullptr;
  return std::unique_ptr<DeviceStageChain>(
      new DeviceStageChain(std::make_unique<Impl>(*f, b, *s, *r)));
}

bool DeviceStageChain::hand_over(LiveVolumeSource& source, const LiveVolumeShape& shape,
                                 std::uint32_t first, std::uint32_t count, bool& new_shape) {
  Impl& m = *impl_;
  cudaStream_t copy = m.copy_stream.get();
  const VolumeDims dims{shape.bscans, shape.ascans, shape.depth};
  // New to the stages only when the input has other dimensions; the pending buffer may also be
  // new when earlier hand-overs came from the host (take_host).
  new_shape = !(dims == m.input_dims) || m.input.size() != dims.bytes();
  const bool new_buffer = !(dims == m.pending_dims) || m.pending.size() != dims.bytes();
  // The last pass must have taken its input before these B-scans overwrite the pending ones.
  if (m.input_taken_recorded) IOCT_CUDA_CHECK(cudaStreamWaitEvent(copy, m.input_taken.get(), 0));
  bool device = false;
  const bool enqueued = source.read_on_device(copy, [&](const DeviceVolumeView& view) {
    device = true;
    if (new_buffer) {
      IOCT_CUDA_CHECK(cudaStreamSynchronize(copy));
      m.pending = cuda::DeviceArray<std::uint8_t>(dims.bytes());
      m.pending_dims = dims;
      if (new_shape) {
        // The B-scans that have not arrived yet are zero, as on the host path.
        IOCT_CUDA_CHECK(cudaMemsetAsync(m.pending.data(), 0, dims.bytes(), copy));
      } else {
        // What the passes took from the host so far (the copy stream waited for the last take).
        IOCT_CUDA_CHECK(cudaMemcpyAsync(m.pending.data(), m.input.data(), dims.bytes(),
                                        cudaMemcpyDeviceToDevice, copy));
      }
    }
    if (view.bscans != dims.bscans || view.ascans != dims.ascans || view.depth != dims.depth) {
      throw std::logic_error("live stages: the device volume's view disagrees with its shape");
    }
    const std::size_t stride = dims.bscan_bytes();
    IOCT_CUDA_CHECK(cudaMemcpyAsync(m.pending.data() + first * stride, view.pixels + first * stride,
                                    count * stride, cudaMemcpyDeviceToDevice, copy));
  });
  if (!enqueued || !device) return false;
  IOCT_CUDA_CHECK(cudaEventRecord(m.pending_ready.get(), copy));
  return true;
}

DeviceStageChain::Taken DeviceStageChain::take(std::uint32_t first, std::uint32_t count) {
  Impl& m = *impl_;
  cudaStream_t stream = m.stream.get();
  IOCT_CUDA_CHECK(cudaStreamWaitEvent(stream, m.pending_ready.get(), 0));
  m.wait_for_render_reads();
  const bool whole = m.reshape_input();
  const std::size_t stride = m.input_dims.bscan_bytes();
  if (whole) {
    first = 0;
    count = m.input_dims.bscans;
  }
  IOCT_CUDA_CHECK(cudaMemcpyAsync(m.input.data() + first * stride,
                                  m.pending.data() + first * stride, count * stride,
                                  cudaMemcpyDeviceToDevice, stream));
  m.record_taken();
  return {first, count};
}

DeviceStageChain::Taken DeviceStageChain::take_host(const Volume& pending, std::uint32_t first,
                                                    std::uint32_t count) {
  Impl& m = *impl_;
  m.pending_dims = VolumeDims::of(pending);
  m.wait_for_render_reads();
  const bool whole = m.reshape_input();
  const std::size_t stride = m.input_dims.bscan_bytes();
  if (whole) {
    first = 0;
    count = m.input_dims.bscans;
  }
  // Pageable memory: staged before the call returns, so the pending volume may change after it.
  cuda::copy_async(m.input.data() + first * stride, pending.bscan(first).data(), count * stride,
                   cudaMemcpyHostToDevice, m.stream.get(), cuda::Payload::volume,
                   "upload of the handed-over B-scans");
  m.record_taken();
  return {first, count};
}

DeviceStageChain::PassTimes DeviceStageChain::run_pass(
    std::uint32_t first, std::uint32_t count, const render::RenderConfig& view,
    render::RgbaImage* frame, const std::function<void()>& while_the_pass_runs) {
  Impl& m = *impl_;
  cudaStream_t stream = m.stream.get();
  const VolumeDims dims = m.input_dims;
  const VolumeRef input = VolumeRef::on_device(m.input.data(), dims, stream);
  const VolumeRef filtered = VolumeRef::on_device(m.filtered.data(), dims, stream);

  // No event orders this pass's filter after the last pass's renderer update, which read the
  // filtered volume on the render stream: the last pass ended waiting for its frame, after it.
  m.started.record(stream);
  const filters::BscanRange outputs = m.filter.filter_group(
      input, MutableVolumeRef::on_device(m.filtered.data(), dims, stream), {first, count});
  m.filtered_done.record(stream);
  // The renderer takes the filtered B-scans (texture, bricks, sums), or in Weiss's modes filters
  // its own, on its stream while the segmentation runs: its searches keep few multiprocessors busy.
  m.update_render_volume(m.wants_bscan_median(view.mode), {first, count}, outputs);
  const segmentation::BscanSpan affected =
      m.segmenter.segment_group(filtered, {outputs.first, outputs.count}, nullptr);
  m.unsynced_first = std::min(m.unsynced_first, affected.first);
  m.unsynced_end = std::max(m.unsynced_end, affected.end());
  m.segmented_done.record(stream);
  IOCT_CUDA_CHECK(cudaStreamWaitEvent(m.render_stream.get(), m.segmented_done.get(), 0));
  m.renderer.update_layers(m.segmenter.device_surfaces());
  m.renderer.render_on_device(view);
  m.rendered_done.record(m.render_stream.get());
  if (frame != nullptr) {
    m.renderer.start_frame_download();  // pinned: it runs during the host's work
    m.frame_copied.record(m.render_stream.get());
  }
  if (while_the_pass_runs) while_the_pass_runs();
  if (frame != nullptr) m.renderer.download_frame(*frame);
  m.pass_done.record(m.render_stream.get());
  IOCT_CUDA_CHECK(cudaEventSynchronize(m.pass_done.get()));
  const std::uint64_t now = ioct::monotonic_ns();

  PassTimes t;
  t.filter_ms = m.filtered_done.ms_since(m.started);
  t.segment_ms = m.segmented_done.ms_since(m.filtered_done);
  // The frame on the device, and with one asked for on the host, as a render between passes is
  // timed; not the host's work meanwhile.
  t.render_ms = (frame != nullptr ? m.frame_copied : m.rendered_done).ms_since(m.segmented_done);
  t.rendered_ns = now;
  // Back from the pass's end (`now`, within microseconds of it) by the device's own times.
  t.segmented_ns = ns_before(now, m.pass_done.ms_since(m.segmented_done));
  t.filtered_ns = ns_before(now, m.pass_done.ms_since(m.filtered_done));
  t.changed_first = affected.first;  // the segmentation's reach covers the filter's outputs
  t.changed_count = affected.count;
  return t;
}

void DeviceStageChain::use_render_volume(render::RenderMode mode) {
  Impl& m = *impl_;
  const bool bscan_median = m.wants_bscan_median(mode);
  if (!m.input_taken_recorded || bscan_median == m.renderer_bscan_median) return;
  const filters::BscanRange all{0, m.input_dims.bscans};
  m.update_render_volume(bscan_median, all, all);
  // The layer reference again: its axial plane comes from the volume's centre-of-mass sums. The
  // surfaces are the last pass's (the render stream waited for them in that pass; again here).
  IOCT_CUDA_CHECK(cudaStreamWaitEvent(m.render_stream.get(), m.segmented_done.get(), 0));
  m.renderer.update_layers(m.segmenter.device_surfaces());
}

void DeviceStageChain::download(Volume& filtered, segmentation::Surfaces& surfaces) {
  Impl& m = *impl_;
  const VolumeDims& d = m.input_dims;
  filtered.reshape(d.bscans, d.ascans, d.depth);
  if (d.bytes() == 0) return;
  cuda::copy_async(filtered.pixels().data(), m.filtered.data(), d.bytes(), cudaMemcpyDeviceToHost,
                   m.stream.get(), cuda::Payload::volume,
                   "copy of the filtered volume to the host");
  m.segmenter.download_surfaces(surfaces, m.stream.get());
}

void DeviceStageChain::bscan_overlay(std::uint32_t bscan, segmentation::RgbImage& image) {
  Impl& m = *impl_;
  const VolumeDims& d = m.input_dims;
  const std::size_t bytes = d.bscan_bytes() * 3;
  m.overlay.resize(bytes);
  segmentation::make_overlay_on_device(m.filtered.data(), d, bscan, m.segmenter.device_surfaces(),
                                       m.overlay.data(), m.stream.get());
  m.overlay_download.add(m.overlay.data(), bytes);
  m.overlay_download.fetch(m.stream.get(), cuda::Payload::other,
                           "copy of the B-scan shown to the host");
  image.width = d.ascans;
  image.height = d.depth;
  m.overlay_download.take(0, image.pixels);
}

void DeviceStageChain::download_surfaces(segmentation::Surfaces& surfaces) {
  Impl& m = *impl_;
  const VolumeDims& d = m.input_dims;
  const bool in_step = &surfaces == m.synced_surfaces && surfaces.bscans == d.bscans &&
                       surfaces.ascans == d.ascans && surfaces.depth == d.depth;
  if (!in_step) {
    m.segmenter.download_surfaces(surfaces, m.stream.get());
  } else {
    const std::uint32_t first = std::min(m.unsynced_first, d.bscans);
    const std::uint32_t end = std::min(m.unsynced_end, d.bscans);
    if (first < end) m.segmenter.download_surfaces(surfaces, {first, end - first}, m.stream.get());
  }
  m.synced_surfaces = &surfaces;
  m.unsynced_first = UINT32_MAX;
  m.unsynced_end = 0;
}

VolumeRef DeviceStageChain::input() const {
  return VolumeRef::on_device(impl_->input.data(), impl_->input_dims, impl_->stream.get());
}

std::uint32_t DeviceStageChain::bscans() const noexcept {
  return impl_->input_dims.bscans;
}

#else  // no CUDA: the stages always work on host volumes

struct DeviceStageChain::Impl {};

std::unique_ptr<DeviceStageChain> DeviceStageChain::make(filters::VolumeFilter&,
                                                         filters::VolumeFilter*,
                                                         segmentation::Segmenter&,
                                                         render::Renderer&,
                                                         const instruments::InstrumentDetector*) {
  return nullptr;
}
bool DeviceStageChain::hand_over(LiveVolumeSource&, const LiveVolumeShape&, std::uint32_t,
                                 std::uint32_t, bool&) {
  return false;
}
DeviceStageChain::Taken DeviceStageChain::take(std::uint32_t, std::uint32_t) {
  throw std::logic_error("live stages: built without CUDA");
}
DeviceStageChain::Taken DeviceStageChain::take_host(const Volume&, std::uint32_t, std::uint32_t) {
  throw std::logic_error("live stages: built without CUDA");
}
DeviceStageChain::PassTimes DeviceStageChain::run_pass(std::uint32_t, std::uint32_t,
                                                       const render::RenderConfig&,
                                                       render::RgbaImage*,
                                                       const std::function<void()>&) {
  throw std::logic_error("live stages: built without CUDA");
}
void DeviceStageChain::use_render_volume(render::RenderMode) {
  throw std::logic_error("live stages: built without CUDA");
}
void DeviceStageChain::download(Volume&, segmentation::Surfaces&) {
  throw std::logic_error("live stages: built without CUDA");
}
void DeviceStageChain::bscan_overlay(std::uint32_t, segmentation::RgbImage&) {
  throw std::logic_error("live stages: built without CUDA");
}
void DeviceStageChain::download_surfaces(segmentation::Surfaces&) {
  throw std::logic_error("live stages: built without CUDA");
}
VolumeRef DeviceStageChain::input() const {
  throw std::logic_error("live stages: built without CUDA");
}
std::uint32_t DeviceStageChain::bscans() const noexcept {
  return 0;
}

#endif

DeviceStageChain::DeviceStageChain(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DeviceStageChain::~DeviceStageChain() = default;

}  // namespace ioct::gpu::live
