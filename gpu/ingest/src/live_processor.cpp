#include "ioct/gpu/ingest/live_processor.hpp"

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cstdio>
#include <sstream>
#include <thread>
#include <vector>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/arrival_forecast.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/concurrency/spin_pause.hpp"
#include "ioct/gpu/ingest/live_pipeline.hpp"
#include "ioct/gpu/ingest/run_summary_json.hpp"
#include "ioct/gpu/latest_wins_worker.hpp"
#include "ioct/gpu/processing/group_check.hpp"
#include "ioct/gpu/volume/png_file.hpp"
#include "ioct/shm/ring_attach.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::gpu {
namespace {

constexpr std::uint64_t kNsPerS = 1'000'000'000;
constexpr int kProblemsPrinted = 10;  // then only counted, so a bad stream cannot flood the log

void sleep_ns(std::uint64_t ns) {
  std::this_thread::sleep_for(std::chrono::nanoseconds(ns));
}

// A latency quantile in milliseconds, "-" when no group arrived.
std::string format_ms(const LatencyHistogram& histogram, double q) {
  if (histogram.count() == 0) return "-";
  char text[32];
  std::snprintf(text, sizeof text, "%.2f ms", static_cast<double>(histogram.quantile(q)) * 1e-6);
  return text;
}

}  // namespace

std::string_view to_string(StopReason reason) noexcept {
  switch (reason) {
    case StopReason::producer_gone:
      return "producer_gone";
    case StopReason::time_limit:
      return "time_limit";
    case StopReason::stop_requested:
      return "stop_requested";
  }
  return "?";
}

void LiveConfig::validate() const {
  const bool plain = !ring_name.empty() && ring_name.find('/') == std::string::npos;
  const bool path = ring_name.size() > 1 && ring_name.front() == '/' && ring_name.rfind('/') > 0 &&
                    ring_name.back() != '/';
  if (!plain && !path) {
    throw ConfigError("ring", "'" + ring_name + "'",
                      "must be a shared-memory name without '/' or an absolute path");
  }
  if (out_dir.empty()) throw ConfigError("out", "''", "must name a directory");
  processing.validate();
  require_real_in_range("wait", wait_s, 0.0, 1e6);
  require_real_in_range("seconds", run_s, 0.0, 1e9);
  require_real_in_range("status_interval", status_interval_s, 0.0, 1e6);
  require_real_in_range("poll_interval", poll_interval_s, 1e-6, 1.0);
  require_real_in_range("spin_window", spin_window_s, 0.0, 0.1);
  if (label.empty() || label.size() >= shm::kReaderLabelBytes) {
    throw ConfigError("label", "'" + label + "'",
                      "must be 1 to " + std::to_string(shm::kReaderLabelBytes - 1) + " characters");
  }
}

// One attachment to the ring, from the first group to the summary.
class LiveProcessor::Session final : public LiveEvents {
 public:
  Session(LiveProcessor& owner, Backend backend, shm::RingReader reader)
      : owner_(owner),
        config_(owner.config_),
        geometry_(reader.geometry()),
        pipeline_(make_live_pipeline(backend, config_.processing, std::move(reader))) {}

  std::string_view backend_name() const noexcept { return pipeline_->backend_name(); }

  StopReason loop() {
    started_ns_ = ioct::monotonic_ns();
    last_status_ns_ = started_ns_;
    const std::uint64_t limit_ns = seconds_to_ns(config_.run_s);
    const std::uint64_t status_ns = seconds_to_ns(config_.status_interval_s);
    const std::uint64_t poll_ns = seconds_to_ns(config_.poll_interval_s);
    // Awake around the next group only where a GPU processes it
    // (concurrency/arrival_forecast.hpp says why not on a CPU).
    const std::uint64_t spin_ns =
        backend_name() == "cuda" ? seconds_to_ns(config_.spin_window_s) : 0;
    for (;;) {
      if (owner_.stop_.load(std::memory_order_relaxed)) return StopReason::stop_requested;
      const std::uint64_t now = ioct::monotonic_ns();
      if (limit_ns > 0 && now - started_ns_ >= limit_ns) return StopReason::time_limit;
      if (status_ns > 0 && now - last_status_ns_ >= status_ns) print_status(now);
      if (owner_.db_range_changed_.exchange(false, std::memory_order_acquire)) {
        const DbScaleConfig scale = owner_.db_range();
        pipeline_->set_db_range(scale);
        owner_.config_.processing.scale = scale;  // for the next attachment's pipeline too
      }

      poll_started_ns_ = ioct::monotonic_ns();
      switch (pipeline_->poll(*this)) {
        case shm::PollStatus::ready:
        case shm::PollStatus::lapped:  // counted by the reader
          break;
        case shm::PollStatus::empty: {
          // Awake around when the next group is due, so it is taken the moment it is published.
          const std::uint64_t sleep =
              idle_sleep_ns(arrivals_, ioct::monotonic_ns(), spin_ns, poll_ns);
          if (sleep > 0) {
            sleep_ns(sleep);
          } else {
            spin_pause();
          }
          break;
        }
        case shm::PollStatus::producer_gone:
          return StopReason::producer_gone;
      }
      owner_.groups_consumed_.store(pipeline_->reader().counters().consumed,
                                    std::memory_order_release);
    }
  }

  // `finish_stage`: false when the loop goes on to wait for the producer's return; the stage
  // then keeps running across the gap and reads the next attachment's volume.
  RunSummary finish(StopReason reason, bool finish_stage) {
    poll_started_ns_ = ioct::monotonic_ns();
    pipeline_->drain(*this);
    write_pending_images();  // a volume the device pipeline reported after its last group
    if (!images_submitted_) {
      // No volume completed (a short run, or the stream ended mid-volume): show what arrived,
      // gaps zeroed, rather than nothing.
      const Volume* volume = nullptr;
      if (const std::optional<VolumeInfo> partial = pipeline_->seal_partial(volume)) {
        prepare_images(*volume, *partial);
        write_pending_images();
      }
    }
    image_writer_.stop();  // the files the summary names are on disk
    const std::uint64_t now = ioct::monotonic_ns();
    if (config_.status_interval_s > 0) print_status(now);
    report_image_failures();
    RunSummary summary;
    if (owner_.stage_ != nullptr && finish_stage) {
      summary.stages = owner_.stage_->finish(config_.out_dir);
    }
    summary.stop_reason = reason;
    summary.geometry = geometry_;
    summary.seconds = static_cast<double>(now - started_ns_) / kNsPerS;
    summary.counters = counters();
    add_image_counts(summary.counters);
    summary.latency = latency_total_;
    summary.images = images_;
    summary.status_flags_seen = status_flags_seen_;
    summary.last_problem = last_problem_;
    return summary;
  }

  // LiveEvents
  void on_volume(const Volume& volume, const VolumeInfo& info) override {
    const std::uint64_t begin = ioct::monotonic_ns();
    ++counters_.volumes_completed;
    owner_.volumes_completed_.store(counters_.volumes_completed, std::memory_order_release);
    if (!info.complete()) {
      ++counters_.volumes_with_gaps;
      // Its gaps were zeroed: the stage takes the whole volume with the next group handed to
      // it (on the device pipeline the group that completed it was handed already).
      stage_needs_whole_volume_ = true;
    }
    if (owner_.observer_) owner_.observer_(volume, info);
    prepare_images(volume, info);
    completion_ns_ += ioct::monotonic_ns() - begin;
  }

  void on_group(const shm::SlotHeader& header, const PlacementResult& placed) override {
    status_flags_seen_ |= header.status_flags;
    arrivals_.observe(header.t_publish_ns, header.group_index);
    // Publish -> in the volume; the time spent on completed volumes' images is not processing.
    // (Clamped: the timestamp comes from another process and is not trusted to be sane.)
    const std::uint64_t now = ioct::monotonic_ns();
    const std::uint64_t elapsed = now > header.t_publish_ns ? now - header.t_publish_ns : 0;
    const std::uint64_t latency = elapsed > completion_ns_ ? elapsed - completion_ns_ : 0;
    // The loop's own time on the group since it asked the ring. With CUDA the group was read
    // and processed during earlier polls, so this is only the host's part of retiring it.
    const std::uint64_t spent = now > poll_started_ns_ ? now - poll_started_ns_ : 0;
    ingest_ns_ = spent > completion_ns_ ? spent - completion_ns_ : 0;
    completion_ns_ = 0;
    latency_total_.record(latency);
    latency_interval_.record(latency);
    ++counters_.groups_processed;
    counters_.bscans_rejected += placed.bscans_rejected;
    counters_.volumes_abandoned += placed.volumes_abandoned;
    // The viewers first: the stages take the group before the completed volume's files are
    // encoded and written, which would otherwise delay that group's frame by their time. (The
    // device pipeline reports a volume after its group: its files are written with the next.)
    hand_to_stage(header, placed);
    write_pending_images();
  }

  void on_rejected(const shm::SlotHeader& header, const std::string& problem) override {
    status_flags_seen_ |= header.status_flags;
    ++counters_.groups_rejected;
    note_problem("group " + std::to_string(header.group_index) + " rejected: " + problem);
  }

  void on_restart(bool volume_abandoned) override {
    if (volume_abandoned) ++counters_.volumes_abandoned;
  }

 private:
  struct PendingImages {
    GrayImage bscan;
    GrayImage enface;
    ImageSet set;
  };

  // The B-scans the group wrote (or the whole volume after gaps were zeroed) to the stage.
  void hand_to_stage(const shm::SlotHeader& header, const PlacementResult& placed) {
    LiveStage* stage = owner_.stage_;
    if (stage == nullptr) return;
    std::uint32_t first = placed.first_position;
    std::uint32_t end = placed.end_position;
    if (stage_needs_whole_volume_) {
      first = 0;
      end = pipeline_->shape().bscans;
      stage_needs_whole_volume_ = false;
    }
    if (end <= first) return;
    const LiveCounters c = counters();
    GroupStamp stamp;
    stamp.group_index = header.group_index;
    stamp.volume_index = header.bscan_count > 0 ? header.bscans[0].volume_index : 0;
    stamp.t_published_ns = header.t_publish_ns;
    stamp.t_processed_ns = ioct::monotonic_ns();
    stamp.ingest_ns = ingest_ns_;
    stamp.groups_consumed = c.groups_consumed;
    stamp.groups_dropped = c.dropped();
    stamp.volumes_completed = c.volumes_completed;
    try {
      stage->on_bscans(*pipeline_, first, end - first, stamp);
    } catch (const std::exception& e) {
      ++counters_.stage_errors;
      note_problem(std::string("live stage: ") + e.what());
    }
  }

  LiveCounters counters() const {
    LiveCounters c = counters_;
    const shm::ReaderCounters& r = pipeline_->reader().counters();
    c.groups_consumed = r.consumed;
    c.dropped_lapped = r.dropped_lapped;
    c.dropped_behind = r.dropped_behind;
    c.resyncs = r.resyncs;
    c.epoch_changes = r.epoch_changes;
    return c;
  }

  void note_problem(const std::string& text) {
    last_problem_ = text;
    if (owner_.log_ != nullptr && problems_printed_ < kProblemsPrinted) {
      owner_.log_->warning(text + (++problems_printed_ == kProblemsPrinted
                                       ? " (further problems are counted, not printed)"
                                       : ""));
    }
  }

  void prepare_images(const Volume& volume, const VolumeInfo& info) {
    PendingImages pending;
    pending.set.volume = info;
    pending.set.bscan_shown = volume.bscans() / 2;
    pending.set.bscan_png = std::filesystem::absolute(config_.out_dir / "bscan.png");
    pending.set.enface_png = std::filesystem::absolute(config_.out_dir / "enface.png");
    pending.bscan = bscan_image(volume, pending.set.bscan_shown);
    pending.enface = enface_image(volume, config_.enface);
    const ClippedFractions clipped = clipped_fractions(volume);
    pending.set.zero_fraction = clipped.zero;
    pending.set.saturated_fraction = clipped.saturated;
    pending_ = std::move(pending);
  }

  // The files are written on the image writer's thread: a busy disk must not hold up the loop.
  void write_pending_images() {
    if (!pending_) return;
    images_submitted_ = true;
    image_writer_.submit([this, pending = std::move(*pending_)] {
      write_png_gray8(pending.set.bscan_png, pending.bscan);
      image_files_written_.fetch_add(1, std::memory_order_relaxed);
      write_png_gray8(pending.set.enface_png, pending.enface);
      image_files_written_.fetch_add(1, std::memory_order_relaxed);
      images_ = pending.set;  // read after image_writer_.stop()
    });
    pending_.reset();
  }

  void add_image_counts(LiveCounters& c) const {
    const LatestWinsWorker::Counts images = image_writer_.counts();
    c.images_written = image_files_written_.load(std::memory_order_relaxed);
    c.images_replaced = 2 * images.replaced;  // a bscan.png and an enface.png each
    c.image_errors = images.failed;
  }

  void report_image_failures() {
    const LatestWinsWorker::Counts images = image_writer_.counts();
    if (images.failed == image_failures_reported_) return;
    image_failures_reported_ = images.failed;
    note_problem(images.problem);
  }

  void print_status(std::uint64_t now) {
    report_image_failures();
    const LiveCounters c = counters();
    const double interval = static_cast<double>(now - last_status_ns_) / kNsPerS;
    const double groups_per_s =
        interval > 0 ? static_cast<double>(c.groups_processed - last_processed_) / interval : 0.0;
    last_status_ns_ = now;
    last_processed_ = c.groups_processed;
    if (owner_.log_ != nullptr) {
      char rate[64];
      std::snprintf(rate, sizeof rate, "%.1f groups/s (%.0f A-scans/s)", groups_per_s,
                    groups_per_s * static_cast<double>(geometry_.ascans_per_group()));
      std::ostringstream line;
      line << rate << ", consumed " << c.groups_consumed << ", dropped " << c.dropped()
           << " (lapped " << c.dropped_lapped << ", behind " << c.dropped_behind << "), rejected "
           << c.groups_rejected << ", volumes " << c.volumes_completed << ", latency p50 "
           << format_ms(latency_interval_, 0.5) << " p99 " << format_ms(latency_interval_, 0.99)
           << (owner_.stage_ != nullptr ? "; " + owner_.stage_->status() : "");
      owner_.log_->info(line.str());
    }
    latency_interval_.reset();
  }

  LiveProcessor& owner_;
  const LiveConfig& config_;
  shm::RingGeometry geometry_;
  std::unique_ptr<LivePipeline> pipeline_;

  LiveCounters counters_;
  LatencyHistogram latency_total_;
  LatencyHistogram latency_interval_;
  std::uint64_t completion_ns_ = 0;
  std::uint64_t poll_started_ns_ = 0;  // the live loop last asked the ring for a group
  ArrivalForecast arrivals_;           // when the producer publishes its next group
  std::uint64_t ingest_ns_ = 0;        // the last group's: read, process, place
  bool stage_needs_whole_volume_ = false;
  std::optional<PendingImages> pending_;
  bool images_submitted_ = false;
  std::optional<ImageSet> images_;  // the last set written (by the image writer's thread)
  std::atomic<std::uint64_t> image_files_written_{0};
  std::uint64_t image_failures_reported_ = 0;
  std::uint32_t status_flags_seen_ = 0;
  std::string last_problem_;
  int problems_printed_ = 0;
  std::uint64_t started_ns_ = 0;
  std::uint64_t last_status_ns_ = 0;
  std::uint64_t last_processed_ = 0;
  LatestWinsWorker image_writer_;  // last: stopped before the members its tasks use go
};

void LiveProcessor::set_db_range(const DbScaleConfig& scale) {
  scale.validate();
  {
    std::lock_guard lock(db_mutex_);
    db_range_ = scale;
  }
  db_range_changed_.store(true, std::memory_order_release);
}

DbScaleConfig LiveProcessor::db_range() const {
  std::lock_guard lock(db_mutex_);
  return db_range_;
}

LiveProcessor::LiveProcessor(LiveConfig config) : config_(std::move(config)) {
  config_.validate();
  db_range_ = config_.processing.scale;
}

RunSummary LiveProcessor::run() {
  std::error_code ec;
  std::filesystem::create_directories(config_.out_dir, ec);
  if (ec || !std::filesystem::is_directory(config_.out_dir, ec)) {
    throw std::runtime_error("cannot create output directory '" + config_.out_dir.string() +
                             "': " + (ec ? ec.message() : "a file of that name exists"));
  }

  RunSummary summary;
  std::string backend_name(to_string(config_.backend));
  bool stage_finished = stage_ == nullptr;
  // The first wait is bounded by wait_s; after the producer went away, waiting for its return
  // is what a service does (until SIGTERM), unless exit_when_producer_gone.
  const std::uint64_t deadline = ioct::monotonic_ns() + seconds_to_ns(config_.wait_s);
  bool waiting_for_return = false;
  for (;;) {
    std::optional<shm::RingReader> reader = attach(deadline, waiting_for_return);
    if (!reader) break;  // stop requested while waiting
    // Only now is "auto" resolved (which initialises the CUDA driver, a fraction of a second):
    // the reader is attached first, so every group published from then on is read or counted
    // as dropped, as with the CPU backend's FFT planning.
    std::string warning;
    const Backend backend = resolve_backend(config_.backend, &warning);
    if (!warning.empty() && log_ != nullptr && !waiting_for_return) log_->warning(warning);
    Session session(*this, backend, std::move(*reader));
    backend_name = session.backend_name();
    attached_.store(true, std::memory_order_release);
    const StopReason reason = session.loop();
    const bool last = reason != StopReason::producer_gone || config_.exit_when_producer_gone;
    summary = session.finish(reason, last);
    stage_finished = stage_finished || last;
    if (last) break;
    // Keep what this attachment did on disk while the next one is awaited.
    write_summary(summary, backend_name);
    waiting_for_return = true;
    if (log_ != nullptr) {
      log_->info("producer gone (ring '" + config_.ring_name +
                 "' closed or replaced): waiting for it to come back (NO SIGNAL)");
    }
  }
  if (!stage_finished) summary.stages = stage_->finish(config_.out_dir);
  write_summary(summary, backend_name);
  return summary;
}

std::optional<shm::RingReader> LiveProcessor::attach(std::uint64_t deadline,
                                                     bool waiting_for_return) {
  shm::AttachWait wait;
  wait.deadline_ns = deadline;
  wait.unbounded = waiting_for_return;
  wait.stop = &stop_;
  wait.report_interval_ns = log_ != nullptr ? seconds_to_ns(config_.status_interval_s) : 0;
  wait.on_waiting = [this](shm::RingErrc last, std::uint64_t waited_ns) {
    char line[160];
    std::snprintf(line, sizeof line, "waiting for the producer (NO SIGNAL) for %.0f s: %s",
                  static_cast<double>(waited_ns) / kNsPerS,
                  std::string(shm::to_string(last)).c_str());
    log_->info(line);
  };
  return shm::attach_when_available(config_.ring_name, shm::ReaderOptions{config_.label}, wait,
                                    config_.wait_s);
}

void LiveProcessor::write_summary(RunSummary& summary, const std::string& backend_name) const {
  summary.ring_name = config_.ring_name;
  summary.backend = backend_name;
  summary.threads = config_.processing.threads;
  summary.scale = config_.processing.scale;
  summary.summary_json = std::filesystem::absolute(config_.out_dir / "summary.json");
  write_text_file_atomically(summary.summary_json, to_json(summary).dump(2) + "\n");
}

}  // namespace ioct::gpu
