// The live volume's stages after processing, on a thread of their own: each new group's B-scans
// are filtered (median 3x3x3, then Gaussian, with the halo from their neighbours), the ILM and the
// RPE segmented on the filtered B-scans, the renderer given both, and the live view rendered. In
// Weiss's layer-aware modes the renderer is given a second volume instead, the same B-scans
// filtered by a 3x3 median per B-scan (render_filter.hpp), while the segmentation keeps the first.
//
// The live loop hands over the B-scans of each group (on_bscans copies them and returns). When the
// stages are still busy with an earlier pass, the new B-scans wait in a pending copy of the live
// volume and the next pass takes everything pending at once ("folding"): with CUDA every group gets
// its own pass; the CPU reference on two cores folds several groups into one pass rather than hold
// up the ring, and says how many it folded. Nothing is skipped: every B-scan handed over is
// filtered, segmented and rendered by some pass.
//
// Where the bytes live: with CUDA stages and a live volume on the device (the CUDA live pipeline),
// the hand-over is a device-to-device copy and a pass enqueues filter -> segment on one stream and
// the renderer's update and frame on another, the volume never crossing to the host
// (DeviceStageChain); otherwise the stages work on host volumes as above (a host live volume with
// CUDA stages is uploaded by the pass).
//
// Frames for viewers: every render of a view (the shared one after every pass, on every change of
// the parameters, and at the frame rate while it auto-rotates; private views after every pass and
// on their changes) is handed to the FramePublisher, which encodes it on a thread of its own and
// publishes it with the current B-scan into the frame ring (a newer frame of the same view replaces
// one still waiting there), and
// the parameters are changed through ViewControl (the view socket). The stages' thread waits for
// new groups, a change, the next frame due or the stop, whichever comes first.
//
// At the end: surfaces.csv, bscan-overlay.png (the centre filtered B-scan with its surfaces),
// render.png (the live view) and one PNG per further mode, and the figures for summary.json.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ioct/concurrency/arrival_forecast.hpp"
#include "ioct/concurrency/latency_histogram.hpp"
#include "ioct/gpu/filters/filter_config.hpp"
#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/instruments/instrument_config.hpp"
#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/latest_wins_worker.hpp"
#include "ioct/gpu/live_stages/view_control.hpp"
#include "ioct/gpu/live_stages/view_set.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/render/render_config.hpp"
#include "ioct/gpu/render/rgba_image.hpp"
#include "ioct/gpu/segmentation/segmentation_config.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"
#include "ioct/shm/frame_ring.hpp"

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

class DeviceStageChain;

// One pass, as the benchmarks see it: CLOCK_MONOTONIC ns when it took its B-scans and when each
// stage's work was done (on the device: when the device finished it).
struct StagesPass {
  std::uint64_t groups = 0;  // hand-overs taken by the pass
  std::uint32_t first = 0, count = 0;
  bool on_device = false;
  bool rendered = false;
  std::uint64_t taken_ns = 0, filtered_ns = 0, segmented_ns = 0, rendered_ns = 0;
  // With instruments.enabled: when the pass's tips were found (on the device chain while the
  // device renders, the classification having run beside the filter and the segmentation; on the
  // host before the render). Else 0. The frame is published after both.
  std::uint64_t detected_ns = 0;
};
class FramePublisher;

struct VolumeStagesConfig {
  Backend backend = Backend::automatic;  // of all three stages
  unsigned cpu_threads = 2;              // of each CPU stage
  // The segmentation's filter, and the renderer's in every mode unless render_filter_by_mode.
  filters::VolumeFilterConfig filter;
  // The renderer's volume filtered as its render mode wants it (render_filter.hpp; stages.filter
  // = auto): in Weiss's modes a second volume, the 3x3 median of each B-scan of the same input,
  // kept only while such a mode is shown; a change of mode re-filters the current volume at once.
  // False: every mode renders the segmentation's volume (an explicit stages.filter).
  bool render_filter_by_mode = true;
  segmentation::SegmentationConfig segmentation;
  segmentation::VolumeSampling sampling;  // also the renderer's voxel spacing
  // Instrument detection after the segmentation of every pass (instruments.enabled), on the
  // processed (unfiltered) B-scans of the pass. With CUDA stages the CUDA detection reads them
  // in place in the device chain: classified beside the filter and the segmentation, the tips
  // located on the host from the classes meanwhile, their distances once the surfaces are down,
  // while the device renders; the frame is published after both.
  instruments::InstrumentConfig instruments;
  render::RenderConfig render;  // the shared view at the start; auto_rotate turns its azimuth
  // Modes rendered once more at the end, each to render-<mode>.png, at the live view.
  std::vector<render::RenderMode> final_modes{render::RenderMode::enhanced,
                                              render::RenderMode::layer_aware,
                                              render::RenderMode::la_mip_composite};
  // The CUDA renderer renders the live view after every pass. The CPU reference takes a large
  // share of both cores for a 1024x768 frame, so it renders after a pass only when this long has
  // passed since its last render (0: after every pass too).
  double cpu_render_interval_s = 2.0;
  // The live view as a PNG, rewritten at most every image_interval_s while running, on a thread of
  // its own so that zlib never delays a frame (empty path or 0 s: only at the end, by finish()).
  std::filesystem::path live_image;
  double image_interval_s = 1.0;
  // The frame ring for ioct-view (shm object name; empty: no frames are published).
  std::string frame_ring;
  std::string frame_group;  // the frame ring's group (ioct-view's); empty: this process's
  // Renders of one view per second at most (auto-rotation, interaction).
  double frame_rate_hz = 60.0;
  // The CPU renderer renders at this fraction of the output size while a view moves, and at full
  // size once it stops (1: always full size). A quarter: 1024x768 takes seconds on two cores,
  // 256x192 a fraction of one (docs/live-view.md).
  double cpu_moving_scale = 0.25;
  // Lower scheduling priority (nice) of the stages' threads, so the processing of the ring always
  // wins the CPU over them.
  int nice = 10;
  // Awake and polling this long on each side of when the next group's hand-over is due
  // (concurrency/arrival_forecast.hpp), so the pass starts without a sleeping thread's wake-up;
  // 0: wait asleep only. Only where a stage runs on the GPU (on a CPU the threads sleep).
  // ioct-gpu sets it from ring.spin_window_s, as the live loop's.
  double spin_window_s = 1e-3;
  // Called on the stages' thread after every pass (benchmarks, tests); keep it short.
  std::function<void(const StagesPass&)> on_pass;

  // Throws ConfigError naming the first bad key.
  void validate() const;
};

class VolumeStages final : public LiveStage, public ViewControl {
 public:
  // Validates the config. The backends are made on the stages' thread, which starts here; a
  // backend that cannot be made (e.g. --backend cuda without a GPU) is reported by finish() and
  // status(), and the stages then take nothing.
  explicit VolumeStages(VolumeStagesConfig config);
  ~VolumeStages() override;
  VolumeStages(const VolumeStages&) = delete;
  VolumeStages& operator=(const VolumeStages&) = delete;

  void on_bscans(LiveVolumeSource& source, std::uint32_t first, std::uint32_t count,
                 const GroupStamp& stamp) override;
  std::string status() const override;
  nlohmann::json finish(const std::filesystem::path& out_dir) override;

  // ViewControl
  ViewParams params() const override;
  std::uint64_t set_params(const nlohmann::json& changes) override;
  std::uint64_t open_view(std::uint64_t view, const nlohmann::json& changes) override;
  std::uint64_t set_view(std::uint64_t view, const nlohmann::json& changes) override;
  void close_view(std::uint64_t view) override;
  ViewSnapshot snapshot(std::chrono::milliseconds timeout) override;
  nlohmann::json instruments() const override;

  // The backends the stages' thread made ("filter ... cuda, segmentation cuda, ..."); empty until
  // it has made them (B-scans handed over before then wait on the host and are uploaded by the
  // first pass).
  std::string backends() const;

  // The state after finish() (tests).
  const Volume& filtered() const noexcept { return filtered_; }
  const segmentation::Surfaces& surfaces() const noexcept { return surfaces_; }
  const instruments::InstrumentFindings& findings() const noexcept { return findings_; }
  // The last frame read back to the host (after finish(): the last one it rendered), without a
  // frame ring: with one, the publisher takes each frame's pixels.
  const render::RgbaImage& frame() const noexcept { return image_; }

 private:
  struct Figures {
    std::uint64_t passes = 0;
    std::uint64_t groups = 0;         // hand-overs taken by the passes
    std::uint64_t groups_folded = 0;  // hand-overs that shared a pass with a later one
    std::uint64_t largest_fold = 0;   // most hand-overs in one pass
    std::uint64_t bscans = 0;         // B-scans taken (sum over passes)
    std::uint64_t renders = 0;
    std::uint64_t interactive_renders = 0;  // between passes: changes, rotation, private views
    std::uint64_t frames_published = 0;
    std::uint64_t frame_errors = 0;
    LatencyHistogram pass;         // take -> rendered
    LatencyHistogram filter;       // per pass
    LatencyHistogram segment;      // per pass
    LatencyHistogram instruments;  // per pass, when enabled
    std::string instruments_line;  // describe() of the latest findings
    nlohmann::json instruments_json;
    LatencyHistogram render;    // per render
    std::string problem;        // the first failure; the stages stop at it
    std::string frame_problem;  // the last frame that could not be published (not fatal)
  };
  using SnapshotWaiters = std::vector<std::shared_ptr<std::promise<ViewSnapshot>>>;

  void work();
  bool make_backends();
  void run_pass(std::uint32_t first, std::uint32_t count, std::uint64_t groups);
  void run_device_pass(std::uint32_t first, std::uint32_t count, std::uint64_t groups,
                       std::uint64_t taken_ns);
  bool live_image_due(std::uint64_t now_ns) const;
  // The device's memory to the frame ring's status (CUDA stages only; at most once a second).
  void note_device_memory(std::uint64_t now_ns);
  // The instrument detection of the pass's new B-scans [first, first + count) of `input` (the
  // unfiltered volume, host or device) with surfaces_; its time. Returns when it ended.
  std::uint64_t detect_instruments(VolumeRef input, std::uint32_t first, std::uint32_t count);
  // The same in three steps (the device chain: begun with the pass, the tips located from the
  // classes while the device filters and segments, ended with the distances once the surfaces
  // are down, while it renders); the time recorded is the stages' thread's in all three.
  void begin_instruments(VolumeRef input, std::uint32_t first, std::uint32_t count);
  void locate_instruments();
  std::uint64_t end_instruments();
  // The findings' line and JSON for the status and the summary, once the pass's frame is out.
  void note_instrument_findings();
  // Host path: the pass's new input B-scans [first, first + count) to the renderer, from the
  // volume `mode` renders from; [affected_first, + affected_count) are the B-scans whose filtered
  // pixels or surfaces the pass changed (the segmentation's reach, which contains the filter's).
  void update_renderer(render::RenderMode mode, std::uint32_t first, std::uint32_t count,
                       std::uint32_t affected_first, std::uint32_t affected_count);
  // Before a render in `mode`: the renderer holds the volume `mode` renders from, re-filtered
  // from the current input when the mode wants another filter than the last render's.
  void use_render_volume(render::RenderMode mode);
  // A pass changed B-scans [first, first + count) of the filtered volume or their surfaces.
  void note_bscans_changed(std::uint32_t first, std::uint32_t count);
  // A pass's figures (the render's only when it rendered), then on_pass and the frame ring's count.
  void record_pass(const StagesPass& pass, std::uint64_t filter_ns, std::uint64_t segment_ns,
                   std::uint64_t render_ns);
  // The shared view to render now and the snapshots waiting for it (under the lock).
  DueRender take_shared_render(SnapshotWaiters& waiters);
  // Renders views between passes (interaction, rotation, private views).
  void render_views(const std::vector<DueRender>& renders, SnapshotWaiters& waiters);
  // The render in image_ to the frame ring, to the snapshots waiting for it, and its figures.
  void deliver(const DueRender& render, std::uint64_t rendered_ns, SnapshotWaiters& waiters);
  void publish_frame(const DueRender& render, std::uint64_t rendered_ns);
  // The B-scan pair through the nearest tip of new findings into tip_bscans_, once: on the device
  // chain while the device renders the pass's frame, else when the frame is published (which
  // hands it to the publisher, with that frame).
  void cut_tip_bscans();
  // The instrument a frame of `shown` carries, placed in its render.
  shm::FrameInstrument instrument_for(const render::RenderConfig& shown) const;
  // A change of the views under the lock, then the stages' thread woken; returns the generation.
  std::uint64_t change_views(const std::function<std::uint64_t(ViewSet&, std::uint64_t)>& change);
  render::RenderConfig live_view() const;
  void write_live_image(std::uint64_t now_ns);
  void fail(const std::string& what);
  nlohmann::json write_outputs(const std::filesystem::path& out_dir);

  const VolumeStagesConfig config_;
  std::unique_ptr<FramePublisher> publisher_;  // null without a frame ring

  // Handed over by the live loop, guarded by mutex_.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  Volume pending_;
  std::uint32_t dirty_first_ = 0;
  std::uint32_t dirty_end_ = 0;
  std::uint64_t dirty_groups_ = 0;
  bool dirty_on_device_ = false;  // the pending B-scans are in device_'s pending volume
  bool stop_ = false;
  bool accepting_ = true;  // false once a stage failed
  Figures figures_;
  std::string backends_;  // "filter cuda, segmentation cuda, render cuda"
  ViewSet views_;
  GroupStamp pending_stamp_;             // the newest group handed over
  std::uint64_t last_published_ns_ = 0;  // of the previous group (for the period)
  std::uint64_t last_group_index_ = 0;
  std::uint64_t group_period_ns_ = 0;  // smoothed: the rate the view shows
  // When the next group is handed over (the stages' thread is awake around it); the count of
  // hand-overs, which the thread watches while it spins outside the lock.
  ArrivalForecast handovers_;
  std::atomic<std::uint64_t> handed_over_{0};
  bool have_volume_ = false;  // a pass has run: there is something to render
  SnapshotWaiters snapshot_waiters_;

  // The stages' own, touched only by their thread (and by finish() after it ended); device_
  // also by on_bscans, under mutex_. It outlives the renderer, which works on its stream.
  std::unique_ptr<DeviceStageChain> device_;
  std::unique_ptr<filters::VolumeFilter> filter_;
  std::unique_ptr<segmentation::Segmenter> segmenter_;
  std::unique_ptr<instruments::InstrumentDetector> detector_;  // null unless enabled
  instruments::InstrumentFindings findings_;
  instruments::TipBscans tip_bscans_;        // through the nearest tip, cut when frames need them
  std::uint64_t instruments_so_far_ns_ = 0;  // the steps before end_instruments(), this pass
  // Where the pair through the nearest tip stands: the publisher has the findings' pair, or the
  // findings are new since, their pair not yet cut into tip_bscans_, or cut.
  enum class TipPair { handed_over, findings_new, cut };
  TipPair tip_pair_ = TipPair::handed_over;
  std::unique_ptr<render::Renderer> renderer_;
  // The renderer's own filter (Weiss's per-B-scan median), null unless render_filter_by_mode; on
  // the host path its volume render_filtered_, kept only while the renderer holds it.
  std::unique_ptr<filters::VolumeFilter> render_filter_;
  Volume render_filtered_;
  bool renderer_bscan_median_ = false;  // host path: the renderer holds render_filtered_
  std::unique_ptr<LatestWinsWorker> image_writer_;  // render.png, off the stages' thread
  Volume input_;
  Volume filtered_;
  segmentation::Surfaces surfaces_;
  render::RgbaImage image_;
  GroupStamp shown_stamp_;   // the newest group in the volume the renderer has
  bool bscan_stale_ = true;  // a pass changed the B-scan shown since the publisher encoded it
  std::uint32_t bscan_shown_ = 0;
  std::uint64_t last_render_ns_ = 0;
  std::uint64_t last_image_ns_ = 0;
  bool uses_device_ = false;   // a stage runs on the GPU: its memory is reported
  std::uint64_t spin_ns_ = 0;  // the stages' thread's spin window: config's on the GPU, else 0
  std::uint64_t last_memory_ns_ = 0;

  std::thread thread_;
};

}  // namespace ioct::gpu::live
