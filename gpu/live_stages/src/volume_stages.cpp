#include "ioct/gpu/live_stages/volume_stages.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/cuda/device_memory.hpp"
#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/instruments/findings_json.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/live_stages/frame_publisher.hpp"
#include "ioct/gpu/live_stages/render_filter.hpp"
#include "ioct/gpu/render/frame_setup.hpp"
#include "ioct/gpu/render/png_rgba.hpp"
#include "ioct/gpu/render/render_params_json.hpp"
#include "ioct/gpu/render/renderer.hpp"
#include "ioct/gpu/segmentation/overlay_image.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/gpu/segmentation/surfaces_csv.hpp"
#include "ioct/shm/shm_object.hpp"

#include "device_stage_chain.hpp"
#include "forecast_wait.hpp"
#include "frame_instrument.hpp"
#include "thread_nice.hpp"

namespace ioct::gpu::live {
namespace {

double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}

nlohmann::json percentiles(const LatencyHistogram& h) {
  if (h.count() == 0) return nullptr;
  return {{"count", h.count()},
          {"p50", ms(h.quantile(0.5))},
          {"p99", ms(h.quantile(0.99))},
          {"max", ms(h.max())}};
}

// The surfaces in a few numbers: how much of the volume has a retina, and where.
nlohmann::json describe(const segmentation::Surfaces& s) {
  std::uint64_t with_retina = 0;
  for (const segmentation::BscanVerdict v : s.verdict) {
    if (v == segmentation::BscanVerdict::retina) ++with_retina;
  }
  std::uint64_t measured = 0;
  std::uint64_t bridged = 0;
  double ilm_sum = 0.0;
  double rpe_sum = 0.0;
  std::uint64_t both = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.state[i] == segmentation::SurfaceState::measured) ++measured;
    if (s.state[i] == segmentation::SurfaceState::bridged) ++bridged;
    if (std::isfinite(s.ilm[i]) && std::isfinite(s.rpe[i])) {
      ilm_sum += s.ilm[i];
      rpe_sum += s.rpe[i];
      ++both;
    }
  }
  nlohmann::json j = {{"bscans", s.bscans},
                      {"ascans_per_bscan", s.ascans},
                      {"bscans_with_retina", with_retina},
                      {"ascans_measured", measured},
                      {"ascans_bridged", bridged}};
  j["ilm_mean_px"] = both > 0 ? nlohmann::json(ilm_sum / static_cast<double>(both)) : nullptr;
  j["rpe_mean_px"] = both > 0 ? nlohmann::json(rpe_sum / static_cast<double>(both)) : nullptr;
  return j;
}

std::string mode_file(render::RenderMode mode) {
  return "render-" + std::string(render::to_string(mode)) + ".png";
}

ViewTiming view_timing(const VolumeStagesConfig& config, bool cpu_renderer) {
  ViewTiming timing;
  timing.frame_rate_hz = config.frame_rate_hz;
  timing.reduce_while_moving = cpu_renderer && config.cpu_moving_scale < 1.0;
  timing.moving_scale = config.cpu_moving_scale;
  return timing;
}

// The B-scan a frame shows: slice.bscan, or the centre one (-1), within the volume.
std::uint32_t shown_bscan(const render::SliceConfig& slice, std::uint32_t bscans) {
  if (slice.bscan < 0) return bscans / 2;
  return static_cast<std::uint32_t>(std::min<std::int64_t>(slice.bscan, bscans - 1));
}

}  // namespace

void VolumeStagesConfig::validate() const {
  require_integer_in_range("stages.threads", cpu_threads, 1, 64);
  filter.validate();
  segmentation.validate();
  sampling.validate();
  instruments.validate();
  render.validate();
  require_real_in_range("stages.cpu_render_interval", cpu_render_interval_s, 0.0, 3600.0);
  require_real_in_range("stages.image_interval", image_interval_s, 0.0, 3600.0);
  require_real_in_range("stages.frame_rate", frame_rate_hz, 0.1, 1000.0);
  require_real_in_range("stages.cpu_moving_scale", cpu_moving_scale, 0.05, 1.0);
  require_real_in_range("ring.spin_window", spin_window_s, 0.0, 0.1);
  if (!frame_ring.empty()) {
    if (const std::string problem = shm::object_name_problem(frame_ring); !problem.empty()) {
      throw ConfigError("stages.frames", "'" + frame_ring + "'", problem);
    }
  }
  if (nice < 0 || nice > 19) {
    throw ConfigError("stages.nice", format_value(std::int64_t{nice}), "must be in [0, 19]");
  }
}

VolumeStages::VolumeStages(VolumeStagesConfig config)
    : config_(std::move(config)),
      views_(config_.render, view_timing(config_, false), ioct::monotonic_ns()) {
  config_.validate();
  if (!config_.frame_ring.empty()) {
    shm::FrameRingConfig ring;
    ring.name = config_.frame_ring;
    ring.group = config_.frame_group;
    // Its encoding thread waits asleep until the stages know whether a GPU renders
    // (make_backends).
    publisher_ = std::make_unique<FramePublisher>(ring, config_.nice);
  }
  thread_ = std::thread([this] { work(); });
}

VolumeStages::~VolumeStages() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void VolumeStages::on_bscans(LiveVolumeSource& source, std::uint32_t first, std::uint32_t count,
                             const GroupStamp& stamp) {
  std::unique_lock lock(mutex_);
  // The period between groups, smoothed (1/8 per group), from the producer's publish times; a
  // stamp going backwards (a producer restart) starts over.
  if (last_published_ns_ != 0 && stamp.t_published_ns > last_published_ns_ &&
      stamp.group_index > last_group_index_) {
    const std::uint64_t sample =
        (stamp.t_published_ns - last_published_ns_) / (stamp.group_index - last_group_index_);
    group_period_ns_ = group_period_ns_ == 0 ? sample : (7 * group_period_ns_ + sample) / 8;
  }
  last_published_ns_ = stamp.t_published_ns;
  last_group_index_ = stamp.group_index;
  if (publisher_) publisher_->note_group(stamp, group_period_ns_);
  if (count == 0) return;
  if (!accepting_) return;
  pending_stamp_ = stamp;
  const LiveVolumeShape shape = source.shape();
  bool new_shape = false;
  // To the device once the CUDA stages exist and no host hand-over waits for a pass (before
  // they exist, e.g. at start-up, B-scans wait in pending_ and the pass uploads them).
  const bool host_pending = dirty_groups_ > 0 && !dirty_on_device_;
  if (device_ != nullptr && !host_pending &&
      device_->hand_over(source, shape, first, count, new_shape)) {
    dirty_on_device_ = true;
  } else {
    dirty_on_device_ = false;
    new_shape = !shape.fits(pending_);
    if (new_shape) {
      // The B-scans that have not arrived yet are zero, and the next pass starts over.
      pending_.reshape(shape.bscans, shape.ascans, shape.depth);
      std::ranges::fill(pending_.pixels(), std::uint8_t{0});
    }
    source.copy_bscans(first, count, pending_);
  }
  if (new_shape) {
    dirty_first_ = 0;
    dirty_end_ = shape.bscans;
  } else if (dirty_groups_ == 0) {
    dirty_first_ = first;
    dirty_end_ = first + count;
  } else {
    dirty_first_ = std::min(dirty_first_, first);
    dirty_end_ = std::max(dirty_end_, first + count);
  }
  ++dirty_groups_;
  handovers_.observe(ioct::monotonic_ns(), stamp.group_index);
  handed_over_.fetch_add(1, std::memory_order_release);
  lock.unlock();
  wake_.notify_all();
}

void VolumeStages::work() {
  // Below the processing; the stages' worker threads made from here inherit it.
  set_this_thread_nice(config_.nice);
  if (!make_backends()) return;
  // Views due get their turn between passes, so a CPU that folds pass after pass still answers
  // the viewers.
  bool pass_last = false;
  for (;;) {
    std::uint32_t first = 0;
    std::uint32_t count = 0;
    std::uint64_t groups = 0;
    std::uint64_t taken_ns = 0;
    std::vector<DueRender> renders;
    SnapshotWaiters waiters;
    {
      std::unique_lock lock(mutex_);
      // New groups, a change, the next frame due (auto-rotation, a view that stopped moving) or
      // the stop, whichever comes first.
      bool views_due = false;
      for (;;) {
        const std::uint64_t now = ioct::monotonic_ns();
        const std::uint64_t due = have_volume_ ? views_.next_due_ns(now) : UINT64_MAX;
        views_due = due <= now;
        if (stop_ || dirty_groups_ > 0 || views_due) break;
        wait_for_next(lock, wake_, handovers_, handed_over_, spin_ns_,
                      due == UINT64_MAX ? UINT64_MAX : due - now);
      }
      if (dirty_groups_ == 0 && stop_) return;  // stopped with nothing pending
      if (dirty_groups_ == 0 || (pass_last && views_due && !stop_)) {
        renders = views_.take_due(ioct::monotonic_ns());
        if (std::ranges::any_of(renders,
                                [](const DueRender& r) { return r.view_id == kSharedView; })) {
          waiters.swap(snapshot_waiters_);
        }
      }
      if (renders.empty() && dirty_groups_ > 0) {
        taken_ns = ioct::monotonic_ns();
        if (device_ != nullptr) {
          // The input is the chain's, on the device; the pending B-scans are in its pending
          // volume, or in pending_ (a host live volume), uploaded here.
          const std::uint32_t n = dirty_end_ - dirty_first_;
          const DeviceStageChain::Taken taken = dirty_on_device_
                                                    ? device_->take(dirty_first_, n)
                                                    : device_->take_host(pending_, dirty_first_, n);
          first = taken.first;
          count = taken.count;
        } else if (!input_.same_shape(pending_)) {
          input_ = pending_;
          first = 0;
          count = pending_.bscans();
        } else {
          first = dirty_first_;
          count = dirty_end_ - dirty_first_;
          const std::size_t n = input_.bscan_pixels();
          std::copy_n(pending_.bscan(first).data(), count * n, input_.bscan(first).data());
        }
        groups = dirty_groups_;
        dirty_groups_ = 0;
        shown_stamp_ = pending_stamp_;
      }
    }
    pass_last = groups > 0;
    try {
      if (groups > 0 && device_ != nullptr) {
        run_device_pass(first, count, groups, taken_ns);
      } else if (groups > 0) {
        run_pass(first, count, groups);
      } else {
        render_views(renders, waiters);
      }
    } catch (const std::exception& e) {
      fail(e.what());
      return;
    }
  }
}

bool VolumeStages::make_backends() {
  try {
    std::string warning;
    const Backend backend = resolve_backend(config_.backend, &warning);
    filter_ = filters::make_volume_filter(backend, config_.filter, config_.cpu_threads);
    segmenter_ = segmentation::make_segmenter(backend, config_.segmentation, config_.sampling,
                                              config_.cpu_threads);
    renderer_ = render::make_renderer(backend, config_.cpu_threads);
    if (config_.render_filter_by_mode) {
      render_filter_ = filters::make_volume_filter(
          backend, render_filter_for(render::RenderMode::layer_aware, config_.filter),
          config_.cpu_threads);
    }
    if (config_.instruments.enabled) {
      detector_ = instruments::make_instrument_detector(backend, config_.instruments,
                                                        config_.sampling, config_.cpu_threads);
    }
    const bool cpu_renderer = renderer_->backend_name() == "cpu";
    uses_device_ = filter_->backend_name() == "cuda" || segmenter_->backend_name() == "cuda" ||
                   renderer_->backend_name() == "cuda";
    // Awake around the next group and frame only where a GPU does the work
    // (concurrency/arrival_forecast.hpp says why not on a CPU).
    spin_ns_ = uses_device_ ? ioct::seconds_to_ns(config_.spin_window_s) : 0;
    if (publisher_ != nullptr)
      publisher_->set_spin_window(uses_device_ ? config_.spin_window_s : 0.0);
    // CUDA stages (and CUDA detection, which reads the chain's unfiltered input in place) keep
    // the volume on the device; any CPU stage takes host volumes.
    auto device = DeviceStageChain::make(*filter_, render_filter_.get(), *segmenter_, *renderer_,
                                         detector_.get());
    std::lock_guard lock(mutex_);
    device_ = std::move(device);
    views_.set_timing(view_timing(config_, cpu_renderer));
    backends_ = "filter " + std::string(filters::filter_name(config_.filter)) + " " +
                std::string(filter_->backend_name()) +
                (render_filter_ != nullptr
                     ? " (layer-aware, la-mip, axial-colorization render " +
                           std::string(filters::filter_name(render_filter_->config())) + ")"
                     : std::string()) +
                ", segmentation " + std::string(segmenter_->backend_name()) + ", render " +
                std::string(renderer_->backend_name()) +
                (detector_ != nullptr ? ", instruments " + std::string(detector_->backend_name())
                                      : std::string());
    return true;
  } catch (const std::exception& e) {
    fail(std::string("cannot start the stages: ") + e.what());
    return false;
  }
}

void VolumeStages::fail(const std::string& what) {
  {
    std::lock_guard lock(mutex_);
    if (figures_.problem.empty()) figures_.problem = what;
    accepting_ = false;
    dirty_groups_ = 0;
    have_volume_ = false;
    for (const auto& waiter : snapshot_waiters_) {
      waiter->set_exception(
          std::make_exception_ptr(std::runtime_error("the stages stopped: " + what)));
    }
    snapshot_waiters_.clear();
  }
  wake_.notify_all();
}

render::RenderConfig VolumeStages::live_view() const {
  std::lock_guard lock(mutex_);
  return views_.shared(ioct::monotonic_ns());
}

void VolumeStages::cut_tip_bscans() {
  if (tip_pair_ != TipPair::findings_new) return;
  // From the processed volume the detector read: the filters erase a tool's thin reflex.
  if (const instruments::InstrumentTip* tip = findings_.nearest_tip()) {
    instruments::cut_tip_bscans(device_ != nullptr ? device_->input() : VolumeRef::on_host(input_),
                                *tip, config_.sampling, tip_bscans_);
  }
  tip_pair_ = TipPair::cut;
}

DueRender VolumeStages::take_shared_render(SnapshotWaiters& waiters) {
  std::lock_guard lock(mutex_);
  views_.volume_changed();
  waiters.swap(snapshot_waiters_);
  return views_.take_shared(ioct::monotonic_ns());
}

void VolumeStages::render_views(const std::vector<DueRender>& renders, SnapshotWaiters& waiters) {
  for (const DueRender& render : renders) {
    const std::uint64_t t0 = ioct::monotonic_ns();
    use_render_volume(render.config.mode);  // a change of mode re-filters here, not a pass later
    renderer_->render(render.config, image_);
    const std::uint64_t t1 = ioct::monotonic_ns();
    {
      std::lock_guard lock(mutex_);
      ++figures_.renders;
      ++figures_.interactive_renders;
      figures_.render.record(t1 - t0);
    }
    if (publisher_) publisher_->note_render_time(t1 - t0);
    deliver(render, t1, waiters);
  }
}

void VolumeStages::deliver(const DueRender& render, std::uint64_t rendered_ns,
                           SnapshotWaiters& waiters) {
  // A snapshot and the live image copy the frame before the viewers' publisher takes its pixels
  // (it swaps them out, to encode them on a thread of its own).
  if (render.view_id == kSharedView) {
    if (!waiters.empty()) {
      ViewSnapshot shot;
      shot.image = image_;
      shot.params = render::to_json(render.config);
      shot.generation = render.generation;
      shot.group_index = shown_stamp_.group_index;
      for (const auto& waiter : waiters) waiter->set_value(shot);
      waiters.clear();
    }
    write_live_image(rendered_ns);
  }
  if (publisher_) publish_frame(render, rendered_ns);
}

void VolumeStages::publish_frame(const DueRender& render, std::uint64_t rendered_ns) {
  try {
    const std::uint32_t bscans = device_ != nullptr ? device_->bscans() : filtered_.bscans();
    const std::uint32_t bscan = shown_bscan(render.config.slice, bscans);
    if (bscan_stale_ || bscan != bscan_shown_) {
      // On the device path the picture is drawn there: only it comes to the host.
      segmentation::RgbImage overlay;
      if (device_ != nullptr) {
        device_->bscan_overlay(bscan, overlay);
      } else {
        overlay = segmentation::make_overlay(filtered_, bscan, surfaces_);
      }
      publisher_->set_bscan(std::move(overlay), bscan, bscans);
      bscan_stale_ = false;
      bscan_shown_ = bscan;
    }
    if (tip_pair_ != TipPair::handed_over) {
      cut_tip_bscans();
      publisher_->set_tip_bscans(findings_.nearest_tip() != nullptr ? &tip_bscans_ : nullptr);
      tip_pair_ = TipPair::handed_over;
    }
    shm::FrameMeta meta{};
    meta.view_id = render.view_id;
    meta.params_generation = render.generation;
    meta.group_index = shown_stamp_.group_index;
    meta.volume_index = shown_stamp_.volume_index;
    meta.t_group_published_ns = shown_stamp_.t_published_ns;
    meta.t_group_processed_ns = shown_stamp_.t_processed_ns;
    meta.t_rendered_ns = rendered_ns;
    meta.stereo = render.config.view.stereo ? 1 : 0;
    const std::string_view mode = render::to_string(render.config.mode);
    std::copy_n(mode.data(), std::min(mode.size(), sizeof meta.mode - 1), meta.mode);
    meta.instrument = instrument_for(render.config);
    publisher_->publish(meta, image_);  // takes image_'s pixels; the next render refills it
    std::lock_guard lock(mutex_);
    ++figures_.frames_published;
  } catch (const std::exception& e) {
    // A frame that cannot be made (its B-scan pair, say) costs the viewers that frame, never the
    // pipeline.
    std::lock_guard lock(mutex_);
    ++figures_.frame_errors;
    figures_.frame_problem = e.what();
  }
}

shm::FrameInstrument VolumeStages::instrument_for(const render::RenderConfig& shown) const {
  if (detector_ == nullptr)
    return frame_instrument(nullptr, config_.instruments.warn_rpe_um, nullptr);
  // The render's camera, to place the tip over the picture (the tables are not needed for it).
  std::optional<render::RenderParams> camera;
  const VolumeDims dims = device_ != nullptr ? device_->input().dims() : VolumeDims::of(filtered_);
  if (findings_.nearest_tip() != nullptr && dims.bytes() != 0) {
    try {
      camera = render::bake_params(shown, dims, 0.0f);
    } catch (const std::exception&) {
      // A config the renderer took is baked the same way; without a camera the tip is not placed.
    }
  }
  return frame_instrument(&findings_, config_.instruments.warn_rpe_um, camera ? &*camera : nullptr);
}

void VolumeStages::run_pass(std::uint32_t first, std::uint32_t count, std::uint64_t groups) {
  const std::uint64_t t0 = ioct::monotonic_ns();
  filters::BscanRange outputs{0, input_.bscans()};
  if (!filtered_.same_shape(input_)) {
    filter_->filter_volume(input_, filtered_);
  } else {
    outputs = filter_->filter_group(input_, filtered_, first, count);
  }
  const std::uint64_t t1 = ioct::monotonic_ns();
  const segmentation::BscanSpan affected =
      segmenter_->segment_group(filtered_, {outputs.first, outputs.count}, surfaces_);
  const std::uint64_t t2 = ioct::monotonic_ns();
  const std::uint64_t t2_detected =
      detector_ != nullptr ? detect_instruments(VolumeRef::on_host(input_), first, count) : t2;
  update_renderer(live_view().mode, first, count, affected.first, affected.count);
  note_bscans_changed(affected.first, affected.count);  // contains the filter's outputs
  const bool render_now =
      renderer_->backend_name() != "cpu" || last_render_ns_ == 0 ||
      static_cast<double>(t2_detected - last_render_ns_) * 1e-9 >= config_.cpu_render_interval_s;
  std::uint64_t t3 = t2_detected;
  DueRender shared;
  SnapshotWaiters waiters;
  if (render_now) {
    shared = take_shared_render(waiters);
    use_render_volume(shared.config.mode);  // the mode changed since the update above
    renderer_->render(shared.config, image_);
    t3 = ioct::monotonic_ns();
    last_render_ns_ = t3;
  }

  record_pass(StagesPass{groups, first, count, false, render_now, t0, t1, t2, t3,
                         detector_ != nullptr ? t2_detected : 0},
              t1 - t0, t2 - t1, t3 - t2_detected);
  if (render_now) deliver(shared, t3, waiters);
  if (detector_ != nullptr) note_instrument_findings();
}

void VolumeStages::update_renderer(render::RenderMode mode, std::uint32_t first,
                                   std::uint32_t count, std::uint32_t affected_first,
                                   std::uint32_t affected_count) {
  const bool bscan_median = render_filter_ != nullptr && renders_from_bscan_median(mode);
  if (bscan_median != renderer_bscan_median_ ||
      (bscan_median && !render_filtered_.same_shape(input_))) {
    use_render_volume(mode);  // the first pass in this mode, or a new geometry: all B-scans
  } else if (bscan_median) {
    // The new B-scans' medians (and a halo of one, as the filters report their reach); the
    // surfaces changed over `affected`, which contains them.
    render_filter_->filter_group(input_, render_filtered_, first, count);
    renderer_->update_bscans(render_filtered_, affected_first, affected_count, &surfaces_);
  } else {
    renderer_->update_bscans(filtered_, affected_first, affected_count, &surfaces_);
  }
}

void VolumeStages::use_render_volume(render::RenderMode mode) {
  if (device_ != nullptr) {
    device_->use_render_volume(mode);
    return;
  }
  const bool bscan_median = render_filter_ != nullptr && renders_from_bscan_median(mode);
  if (bscan_median == renderer_bscan_median_ &&
      (!bscan_median || render_filtered_.same_shape(input_))) {
    return;
  }
  if (bscan_median) {
    render_filter_->filter_volume(input_, render_filtered_);
    renderer_->set_volume(render_filtered_, &surfaces_);
  } else {
    render_filtered_ = Volume();  // kept only while shown
    renderer_->set_volume(filtered_, &surfaces_);
  }
  renderer_bscan_median_ = bscan_median;
}

std::uint64_t VolumeStages::detect_instruments(VolumeRef input, std::uint32_t first,
                                               std::uint32_t count) {
  begin_instruments(input, first, count);
  return end_instruments();
}

void VolumeStages::begin_instruments(VolumeRef input, std::uint32_t first, std::uint32_t count) {
  const std::uint64_t t0 = ioct::monotonic_ns();
  // On the processed B-scans: the median filter erases a tool's thin, tilted reflex.
  detector_->begin_group(input, {first, count}, findings_);
  instruments_so_far_ns_ = ioct::monotonic_ns() - t0;
}

void VolumeStages::locate_instruments() {
  const std::uint64_t t0 = ioct::monotonic_ns();
  detector_->locate_tips(findings_);
  instruments_so_far_ns_ += ioct::monotonic_ns() - t0;
}

std::uint64_t VolumeStages::end_instruments() {
  const std::uint64_t t0 = ioct::monotonic_ns();
  detector_->end_group(surfaces_, findings_);
  tip_pair_ = TipPair::findings_new;
  const std::uint64_t t1 = ioct::monotonic_ns();
  std::lock_guard lock(mutex_);
  figures_.instruments.record(std::exchange(instruments_so_far_ns_, 0) + (t1 - t0));
  return t1;
}

void VolumeStages::note_instrument_findings() {
  // After the pass's frame went: the status's line and JSON (0.1 ms on the H100 host) are no
  // part of what the frame waits for.
  std::string line = instruments::describe(findings_);
  nlohmann::json json = instruments::to_json(findings_);
  std::lock_guard lock(mutex_);
  figures_.instruments_line = std::move(line);
  figures_.instruments_json = std::move(json);
}

void VolumeStages::note_bscans_changed(std::uint32_t first, std::uint32_t count) {
  // The B-scan beside the render is downloaded, drawn and encoded again only when a pass changed
  // it: a group touches 16 (+ halo) of 128 B-scans, so most passes leave it as it is.
  if (bscan_shown_ >= first && bscan_shown_ - first < count) bscan_stale_ = true;
}

void VolumeStages::record_pass(const StagesPass& pass, std::uint64_t filter_ns,
                               std::uint64_t segment_ns, std::uint64_t render_ns) {
  {
    std::lock_guard lock(mutex_);
    Figures& f = figures_;
    ++f.passes;
    f.groups += pass.groups;
    f.groups_folded += pass.groups - 1;
    f.largest_fold = std::max(f.largest_fold, pass.groups);
    f.bscans += pass.count;
    f.filter.record(filter_ns);
    f.segment.record(segment_ns);
    if (pass.rendered) {
      ++f.renders;
      f.render.record(render_ns);
    }
    f.pass.record(pass.rendered_ns - pass.taken_ns);
    have_volume_ = true;
  }
  if (config_.on_pass) config_.on_pass(pass);
  if (publisher_) {
    // The newest group the pass took, from its publication by ioct-rt to its render (clamped:
    // the publish time comes from another process).
    const std::uint64_t published = shown_stamp_.t_published_ns;
    const std::uint64_t to_rendered =
        published != 0 && pass.rendered_ns > published ? pass.rendered_ns - published : 0;
    publisher_->note_pass(filter_ns, segment_ns, pass.rendered, render_ns, to_rendered);
    note_device_memory(pass.rendered_ns);
  }
}

void VolumeStages::note_device_memory(std::uint64_t now_ns) {
  // Once a second at most: the query is a driver call.
  constexpr std::uint64_t kIntervalNs = 1'000'000'000;
  if (!uses_device_ || (last_memory_ns_ != 0 && now_ns - last_memory_ns_ < kIntervalNs)) return;
  last_memory_ns_ = now_ns;
  if (const std::optional<DeviceMemory> m = device_memory()) {
    publisher_->note_device_memory(m->used_bytes, m->total_bytes);
  }
}

bool VolumeStages::live_image_due(std::uint64_t now_ns) const {
  if (config_.live_image.empty() || config_.image_interval_s <= 0.0) return false;
  return last_image_ns_ == 0 ||
         static_cast<double>(now_ns - last_image_ns_) * 1e-9 >= config_.image_interval_s;
}

void VolumeStages::run_device_pass(std::uint32_t first, std::uint32_t count, std::uint64_t groups,
                                   std::uint64_t taken_ns) {
  // The frame comes back to the host only when someone looks: viewers (the frame ring), a
  // snapshot waiting, or the live image due.
  SnapshotWaiters waiters;
  const DueRender shared = take_shared_render(waiters);
  const bool frame_wanted =
      publisher_ != nullptr || !waiters.empty() || live_image_due(ioct::monotonic_ns());
  std::uint64_t detected_ns = 0;
  std::function<void()> while_the_pass_runs;
  if (detector_ != nullptr) {
    // The A-scans' classes from the input in place, on the detector's stream beside the filter
    // and the segmentation. Once the pass is enqueued the host locates the tips from the classes
    // while the device still filters and segments; then the surfaces come to the host (a few
    // hundred kB) and the distances are found while it renders, and so is the tip's B-scan pair
    // a frame will carry (cut from the input on the chain's stream, beside the render). The
    // frame, published after both, carries the instrument of the volume state it shows.
    begin_instruments(device_->input(), first, count);
    while_the_pass_runs = [this, &detected_ns] {
      locate_instruments();
      device_->download_surfaces(surfaces_);
      detected_ns = end_instruments();
      if (publisher_ != nullptr) {  // only the publisher takes the pair
        try {
          cut_tip_bscans();
        } catch (const std::exception&) {
          // Not cut: the frame's publication cuts it again, and a failure there costs the
          // viewers that frame (publish_frame), never the pipeline.
        }
      }
    };
  }
  DeviceStageChain::PassTimes t;
  try {
    t = device_->run_pass(first, count, shared.config, frame_wanted ? &image_ : nullptr,
                          while_the_pass_runs);
  } catch (...) {
    // The input is not written again before the detector is done reading it.
    if (detector_ != nullptr) detector_->drop_group();
    throw;
  }
  last_render_ns_ = t.rendered_ns;
  note_bscans_changed(t.changed_first, t.changed_count);
  const auto ns = [](double ms) { return static_cast<std::uint64_t>(ms * 1e6); };
  record_pass(StagesPass{groups, first, count, true, true, taken_ns, t.filtered_ns, t.segmented_ns,
                         t.rendered_ns, detected_ns},
              ns(t.filter_ms), ns(t.segment_ms), ns(t.render_ms));
  if (frame_wanted) deliver(shared, t.rendered_ns, waiters);
  if (detector_ != nullptr) note_instrument_findings();
}

void VolumeStages::write_live_image(std::uint64_t now_ns) {
  if (config_.live_image.empty() || config_.image_interval_s <= 0.0 || image_.width == 0) return;
  if (last_image_ns_ != 0 &&
      static_cast<double>(now_ns - last_image_ns_) * 1e-9 < config_.image_interval_s) {
    return;
  }
  last_image_ns_ = now_ns;
  if (!image_writer_) image_writer_ = std::make_unique<LatestWinsWorker>();
  image_writer_->submit(
      [path = config_.live_image, image = image_] { render::write_png(path, image); });
}

ViewParams VolumeStages::params() const {
  std::lock_guard lock(mutex_);
  return {views_.generation(), render::to_json(views_.shared(ioct::monotonic_ns()))};
}

std::uint64_t VolumeStages::change_views(
    const std::function<std::uint64_t(ViewSet&, std::uint64_t)>& change) {
  std::unique_lock lock(mutex_);
  const std::uint64_t generation = change(views_, ioct::monotonic_ns());
  lock.unlock();
  wake_.notify_all();  // the stages' thread renders the changed view
  return generation;
}

std::uint64_t VolumeStages::set_params(const nlohmann::json& changes) {
  return change_views([&](ViewSet& v, std::uint64_t now) { return v.set_shared(changes, now); });
}

std::uint64_t VolumeStages::open_view(std::uint64_t view, const nlohmann::json& changes) {
  return change_views([&](ViewSet& v, std::uint64_t now) { return v.open(view, changes, now); });
}

std::uint64_t VolumeStages::set_view(std::uint64_t view, const nlohmann::json& changes) {
  return change_views(
      [&](ViewSet& v, std::uint64_t now) { return v.set_camera(view, changes, now); });
}

void VolumeStages::close_view(std::uint64_t view) {
  {
    std::lock_guard lock(mutex_);
    views_.close(view);
  }
  if (publisher_ && view != kSharedView) publisher_->forget_view(view);
}

ViewSnapshot VolumeStages::snapshot(std::chrono::milliseconds timeout) {
  std::future<ViewSnapshot> next;
  {
    std::lock_guard lock(mutex_);
    if (!figures_.problem.empty())
      throw std::runtime_error("the stages stopped: " + figures_.problem);
    if (stop_) throw std::runtime_error("the stages are stopping");
    if (!have_volume_) throw std::runtime_error("nothing rendered yet: no group has arrived");
    auto waiter = std::make_shared<std::promise<ViewSnapshot>>();
    next = waiter->get_future();
    snapshot_waiters_.push_back(std::move(waiter));
    views_.want_full_shared();
  }
  wake_.notify_all();
  if (next.wait_for(timeout) != std::future_status::ready) {
    throw std::runtime_error("no frame within " + std::to_string(timeout.count()) + " ms");
  }
  return next.get();
}

std::string VolumeStages::status() const {
  std::lock_guard lock(mutex_);
  const Figures& f = figures_;
  if (!f.problem.empty()) return "stages stopped: " + f.problem;
  char text[160];
  std::snprintf(text, sizeof text, "stages %llu passes (%llu groups folded), pass p50 %.1f ms",
                static_cast<unsigned long long>(f.passes),
                static_cast<unsigned long long>(f.groups_folded),
                f.pass.count() > 0 ? ms(f.pass.quantile(0.5)) : 0.0);
  if (config_.instruments.enabled) {
    return std::string(text) + "; instruments: " +
           (f.instruments_line.empty() ? std::string("not run yet") : f.instruments_line);
  }
  return text;
}

std::string VolumeStages::backends() const {
  std::lock_guard lock(mutex_);
  return backends_;
}

nlohmann::json VolumeStages::instruments() const {
  if (!config_.instruments.enabled) return {{"enabled", false}};
  std::lock_guard lock(mutex_);
  nlohmann::json j =
      figures_.instruments_json.is_object() ? figures_.instruments_json : nlohmann::json::object();
  j["enabled"] = true;
  j["warn_rpe_um"] = config_.instruments.warn_rpe_um;
  return j;
}

nlohmann::json VolumeStages::finish(const std::filesystem::path& out_dir) {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();  // after the pending B-scans' pass
  LatestWinsWorker::Counts live_images;
  if (image_writer_) {
    image_writer_->stop();  // before finish's own render.png
    live_images = image_writer_->counts();
  }
  {
    std::lock_guard lock(mutex_);
    for (const auto& waiter : snapshot_waiters_) {
      waiter->set_exception(std::make_exception_ptr(std::runtime_error("the stages stopped")));
    }
    snapshot_waiters_.clear();
  }

  nlohmann::json files = nlohmann::json::object();
  std::string problem;
  std::uint64_t passes = 0;
  {
    std::lock_guard lock(mutex_);
    problem = figures_.problem;
    passes = figures_.passes;
  }
  if (problem.empty() && device_ != nullptr && passes > 0) {
    try {
      device_->download(filtered_, surfaces_);  // the files' volume and surfaces
    } catch (const std::exception& e) {
      problem = std::string("reading back the stages' results: ") + e.what();
    }
  }
  if (problem.empty() && filtered_.bscans() > 0) {
    try {
      files = write_outputs(out_dir);
    } catch (const std::exception& e) {
      problem = std::string("writing the stages' files: ") + e.what();
    }
  }

  // ioct-view shows NO SIGNAL from now; the frame still waiting is written first, and counted.
  if (publisher_) publisher_->close();
  std::lock_guard lock(mutex_);
  const Figures& f = figures_;
  nlohmann::json j;
  j["backends"] = backends_;
  j["passes"] = f.passes;
  j["groups"] = f.groups;
  j["groups_folded"] = f.groups_folded;
  j["largest_fold"] = f.largest_fold;
  j["bscans"] = f.bscans;
  j["renders"] = f.renders;
  j["interactive_renders"] = f.interactive_renders;
  j["frame_ring"] = publisher_ ? nlohmann::json(publisher_->name()) : nlohmann::json(nullptr);
  j["frames_published"] = f.frames_published;
  // The publisher's own count: frames refused by the ring (too large) count as errors too.
  const FramePublisher::FrameCounts frames =
      publisher_ ? publisher_->frame_counts() : FramePublisher::FrameCounts{};
  j["frames_written"] = frames.written;
  j["frames_replaced"] = frames.replaced;
  j["frame_errors"] = f.frame_errors + frames.errors;
  j["frame_problem"] = frames.problem.empty() ? f.frame_problem : frames.problem;
  j["live_images_written"] = live_images.done;
  if (live_images.failed > 0) {
    j["live_images_failed"] = live_images.failed;
    j["live_image_problem"] = live_images.problem;
  }
  j["pass_ms"] = percentiles(f.pass);
  j["filter_ms"] = percentiles(f.filter);
  j["segment_ms"] = percentiles(f.segment);
  if (config_.instruments.enabled) {
    j["instruments_ms"] = percentiles(f.instruments);
    j["instruments"] =
        f.instruments_json.is_object() ? f.instruments_json : nlohmann::json(nullptr);
  }
  j["render_ms"] = percentiles(f.render);
  j["surfaces"] = surfaces_.bscans > 0 ? describe(surfaces_) : nlohmann::json(nullptr);
  j["files"] = files;
  j["problem"] = problem;
  return j;
}

nlohmann::json VolumeStages::write_outputs(const std::filesystem::path& out_dir) {
  nlohmann::json files = nlohmann::json::object();
  const auto path = [&](const std::string& name) {
    return std::filesystem::absolute(out_dir / name);
  };

  const std::filesystem::path csv = path("surfaces.csv");
  {
    AtomicFile file(csv);
    segmentation::write_surfaces_csv(file.stream(), surfaces_, config_.sampling.axial_um_per_px);
    file.commit();
  }
  files["surfaces"] = csv.string();

  const std::uint32_t centre = filtered_.bscans() / 2;
  const std::filesystem::path overlay = path("bscan-overlay.png");
  segmentation::write_png_rgb8(overlay, segmentation::make_overlay(filtered_, centre, surfaces_));
  files["bscan_overlay"] = overlay.string();
  files["bscan_overlay_index"] = centre;

  const render::RenderConfig view = live_view();
  use_render_volume(view.mode);
  renderer_->render(view, image_);
  const std::filesystem::path live = path("render.png");
  render::write_png(live, image_);
  files["render"] = live.string();
  files["render_mode"] = std::string(render::to_string(view.mode));
  files["render_azimuth_deg"] = view.view.azimuth_deg;
  for (const render::RenderMode mode : config_.final_modes) {
    if (mode == view.mode) {  // the live view itself: the same image under its mode's name
      std::filesystem::copy_file(live, path(mode_file(mode)),
                                 std::filesystem::copy_options::overwrite_existing);
      files[std::string(render::to_string(mode))] = path(mode_file(mode)).string();
      continue;
    }
    render::RenderConfig c = view;
    c.mode = mode;
    use_render_volume(mode);
    renderer_->render(c, image_);
    const std::filesystem::path file = path(mode_file(mode));
    render::write_png(file, image_);
    files[std::string(render::to_string(mode))] = file.string();
  }
  return files;
}

}  // namespace ioct::gpu::live
