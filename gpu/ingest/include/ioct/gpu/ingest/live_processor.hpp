// The live loop of ioct-gpu: attach to the ring, read each group into a preallocated buffer,
// process it, place it into the volume, and write bscan.png and enface.png each time a volume
// completes. When the producer closes or replaces the ring, run() says so and waits for it to come
// back, then reattaches (a service must survive a restart of ioct-rt); it returns when a time
// limit passes, when request_stop() is called or, with exit_when_producer_gone, when the producer
// goes, after writing summary.json (which describes the last attachment).
//
// A class rather than main() so tests run the very same loop in a thread against a ring they
// publish into.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "ioct/common/log.hpp"
#include "ioct/concurrency/latency_histogram.hpp"
#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/volume/projections.hpp"
#include "ioct/gpu/volume/volume_assembler.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::gpu {

struct LiveConfig {
  std::string ring_name = "ioct-ring";
  std::filesystem::path out_dir = "out";
  Backend backend = Backend::cpu;
  OctProcessorConfig processing;
  EnfaceProjection enface = EnfaceProjection::mean;
  double wait_s = 0.0;              // keep retrying to attach this long (not found / not ready)
  double run_s = 0.0;               // stop after this long attached; 0: no limit
  double status_interval_s = 1.0;   // between status lines; 0: none
  double poll_interval_s = 250e-6;  // sleep when no group is ready
  // Awake and polling this long on each side of when the next group is due
  // (concurrency/arrival_forecast.hpp); 0: only sleep between polls.
  double spin_window_s = 1e-3;
  std::string label = "ioct-gpu";        // shown to the producer in the reader status
  bool exit_when_producer_gone = false;  // finish instead of waiting for the producer's return

  // Throws ConfigError naming the first bad key.
  void validate() const;
};

struct LiveCounters {
  std::uint64_t groups_consumed = 0;  // read intact
  std::uint64_t dropped_lapped = 0;   // overwritten while being read
  std::uint64_t dropped_behind = 0;   // skipped because this reader fell a ring behind
  std::uint64_t resyncs = 0;
  std::uint64_t epoch_changes = 0;     // producer restarts followed
  std::uint64_t groups_rejected = 0;   // a header that does not fit the geometry
  std::uint64_t groups_processed = 0;  // consumed and not rejected
  std::uint64_t bscans_rejected = 0;   // a marker the volume could not take
  std::uint64_t volumes_completed = 0;
  std::uint64_t volumes_with_gaps = 0;  // completed with B-scans missing (zeroed)
  std::uint64_t volumes_abandoned = 0;  // their end never arrived
  std::uint64_t images_written = 0;     // PNG files
  std::uint64_t images_replaced = 0;    // PNG files not written: a newer volume's came first
  std::uint64_t image_errors = 0;       // sets of files whose writing failed
  std::uint64_t stage_errors = 0;       // hand-overs to the live stage that failed
  std::uint64_t dropped() const noexcept { return dropped_lapped + dropped_behind; }
};

enum class StopReason {
  producer_gone,   // the producer closed (or replaced) the ring and exit_when_producer_gone
  time_limit,      // run_s passed
  stop_requested,  // request_stop(), e.g. SIGINT/SIGTERM
};

std::string_view to_string(StopReason reason) noexcept;

// The images on disk and the volume they show.
struct ImageSet {
  std::filesystem::path bscan_png;
  std::filesystem::path enface_png;
  VolumeInfo volume;
  std::uint32_t bscan_shown = 0;    // index of the B-scan in bscan.png
  double zero_fraction = 0.0;       // of the volume's pixels: below db_min
  double saturated_fraction = 0.0;  // of the volume's pixels: above db_max
};

struct RunSummary {
  StopReason stop_reason = StopReason::stop_requested;
  std::string ring_name;
  std::string backend;
  std::uint32_t threads = 1;
  DbScaleConfig scale;
  std::optional<shm::RingGeometry> geometry;  // none when the ring never appeared
  double seconds = 0.0;                       // attached
  LiveCounters counters;
  LatencyHistogram latency;  // publish -> processed into the volume, all groups
  std::optional<ImageSet> images;
  std::uint32_t status_flags_seen = 0;  // SlotHeader::status_flags, OR of all groups
  std::string last_problem;             // the last rejection or image error, if any
  nlohmann::json stages;                // the live stage's part (filters, surfaces, renders)
  std::filesystem::path summary_json;
};

class LiveProcessor {
 public:
  // Called on the processing thread with each completed volume, before its images are written.
  using VolumeObserver = std::function<void(const Volume&, const VolumeInfo&)>;

  // Throws ConfigError for a bad config.
  explicit LiveProcessor(LiveConfig config);

  // Status lines and warnings go here (nullptr: nowhere; not owned). Set before run().
  void set_log(const Log* log) { log_ = log; }
  void set_volume_observer(VolumeObserver observer) { observer_ = std::move(observer); }
  // The stage run on each new group of the live volume (not owned; nullptr: none). Set before
  // run(); its finish() is called at the end of run() and its part goes into summary.json.
  void set_stage(LiveStage* stage) { stage_ = stage; }

  // Runs the loop on the calling thread. Throws shm::RingError when the ring does not appear
  // within wait_s or cannot be read, BackendUnavailable, std::invalid_argument for a geometry the
  // chain cannot process, std::runtime_error when the output directory or summary.json cannot be
  // written. Failing to write an image is counted and reported, not thrown.
  RunSummary run();

  // Makes run() finish soon. Safe from any thread; never blocks.
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }

  // The dB range of the groups processed from now on (the assistant's control): validated here
  // (ConfigError, nothing changed), applied by the loop before its next group. Any thread.
  void set_db_range(const DbScaleConfig& scale);
  DbScaleConfig db_range() const;

  // Progress, readable from other threads while run() goes on.
  bool attached() const noexcept { return attached_.load(std::memory_order_acquire); }
  std::uint64_t groups_consumed() const noexcept {
    return groups_consumed_.load(std::memory_order_acquire);
  }
  std::uint64_t volumes_completed() const noexcept {
    return volumes_completed_.load(std::memory_order_acquire);
  }

 private:
  class Session;
  // Attaches, retrying what a producer starting up or restarting gives; until `deadline` for the
  // first attachment, without limit when `waiting_for_return`. nullopt when stopped meanwhile.
  std::optional<shm::RingReader> attach(std::uint64_t deadline, bool waiting_for_return);
  void write_summary(RunSummary& summary, const std::string& backend_name) const;

  LiveConfig config_;
  const Log* log_ = nullptr;
  VolumeObserver observer_;
  LiveStage* stage_ = nullptr;
  mutable std::mutex db_mutex_;
  DbScaleConfig db_range_;  // under db_mutex_: the newest asked for
  std::atomic<bool> db_range_changed_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> attached_{false};
  std::atomic<std::uint64_t> groups_consumed_{0};
  std::atomic<std::uint64_t> volumes_completed_{0};
  static_assert(std::atomic<bool>::is_always_lock_free, "request_stop() never blocks");
};

}  // namespace ioct::gpu
