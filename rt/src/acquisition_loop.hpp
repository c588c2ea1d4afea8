// The acquisition thread. It owns the digitizer and the galvo output while it runs and is told
// by the safety supervisor whether to run or to park.
//
// Arming: the DAC FIFO is prefilled with the scan, then the followers are started before the
// trigger (galvo output first, digitizer last). Per group: top up the DAC ahead of the beam,
// claim a ring slot, have the digitizer fill its payload in place, stamp the header from the
// sweep counter and the scan schedule, wait until the group's last sweep has ended (an absolute
// CLOCK_MONOTONIC deadline, in slices so a park command is seen) and publish. Faults the thread
// finds (digitizer timeout, k-clock, missed triggers, galvo underrun or fault, deadline misses,
// errors) are posted to the supervisor, which drops emission and commands the park; the thread
// parks when told, or on its own after park_wait.
//
// After start() the thread neither allocates, locks nor logs on its way through a group: what it
// has to say goes out through atomics and lock-free queues that the housekeeping side drains.
// New scan patterns come in through a single-producer single-consumer mailbox and take effect
// where a volume and a group start together; patterns it no longer uses go back through another.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/concurrency/latency_histogram.hpp"
#include "ioct/concurrency/spsc_queue.hpp"
#include "ioct/hal/digitizer.hpp"
#include "ioct/hal/galvo_output.hpp"
#include "ioct/scan/scan_pattern.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "realtime_setup.hpp"
#include "scan_schedule.hpp"
#include "sweep_clock.hpp"

namespace ioct::rt {

struct LoopSettings {
  hal::DigitizerConfig geometry;   // what the digitizer was prepared with
  std::uint32_t extra_status = 0;  // shm::kStatus* that hold for every group (simulated)
  RealtimeRequest realtime;
  // The loop's clock runs this many times faster than the sweeps (a replay faster than real
  // time); 1 for acquisition. Group deadlines and timestamps follow the paced clock.
  double pace_speed = 1.0;
  std::size_t stack_prefault_bytes = 256 * 1024;
  // A group published later than this after its last sweep ended is a deadline miss.
  std::uint64_t publish_slack_ns = 2'000'000;
  // More deadline misses in a row than this is a fault, when the thread runs SCHED_FIFO: a thread
  // without real-time scheduling has no deadline to keep (its misses are counted, not faults)
  // unless deadline_faults_without_realtime says otherwise.
  std::uint32_t max_consecutive_misses = 3;
  bool deadline_faults_without_realtime = false;
  // More sweeps lost in one group than this is a trigger loss (a fault).
  std::uint32_t max_missed_sweeps_per_group = 8;
  // How often the thread looks at its command while it waits (sleep slice).
  std::uint64_t check_interval_ns = 1'000'000;
  // The DAC FIFO is kept this many groups of sweeps ahead of the beam (capped by its capacity).
  std::uint32_t feed_ahead_groups = 3;
  // Galvo lead compensation: DAC sample n carries the trajectory of sweep n + lead, so that the
  // mirrors, which lag their command, are where the markers say when the sweep is recorded. The
  // shift is made here; the galvo output is prepared with lead_samples = 0.
  std::uint32_t galvo_lead_samples = 0;
  // After posting a fault, how long the thread waits for the park command before parking anyway.
  std::uint64_t park_wait_ns = 20'000'000;
};

struct LoopCounters {
  std::uint64_t groups_generated = 0;
  std::uint64_t groups_published = 0;
  std::uint64_t groups_dropped = 0;       // claimed but not published (incomplete, parked)
  std::uint64_t deadline_misses = 0;      // published later than their deadline, by the loop
  std::uint64_t worst_lateness_ns = 0;    // the furthest past its deadline a group was ready
  std::uint64_t generation_ns_total = 0;  // time acquire_group() took, summed over the groups
  std::uint64_t generation_ns_max = 0;
  std::uint64_t missed_sweeps = 0;  // reported by the digitizer
  // Groups the digitizer delivered late (hal::kGroupLate: the simulator's workers behind); not
  // deadline misses of the loop, and never a fault.
  std::uint64_t simulator_late_groups = 0;
  std::uint64_t simulator_worst_lateness_ns = 0;  // the furthest past its last sweep such a group
  std::uint64_t arms = 0;
  std::uint64_t parks = 0;
  std::uint64_t scan_changes = 0;
  std::uint32_t scan_generation = 0;
  std::uint32_t scan_pattern_id = 0;
  std::uint64_t dac_fill_last = 0;       // DAC FIFO fill before the last top-up, samples
  std::uint64_t dac_fill_min = 0;        // the lowest such fill since arming
  std::uint64_t dac_underruns = 0;       // as the galvo output reports them, since arming
  std::uint64_t page_faults = 0;         // the thread's page faults since it started
  std::uint64_t page_faults_steady = 0;  // since the first lap over the ring after arming
};

// What the supervisor reads each poll.
struct LoopReport {
  bool streaming = false;           // galvo and digitizer running
  std::uint64_t serving_cycle = 0;  // the run command (cycle) the flags below belong to
  bool verified = false;            // a good group published and the galvo clocking out, this cycle
  std::uint32_t faults = 0;         // kFault* posted this cycle
  std::uint64_t heartbeat_ns = 0;
};

// simulator_behind: a late group after on-time ones (value: lateness in us, capped).
enum class LoopEventKind : std::uint8_t { armed, parked, fault, scan_changed, simulator_behind };
struct LoopEvent {
  std::uint64_t time_ns = 0;
  LoopEventKind kind = LoopEventKind::armed;
  std::uint32_t value = 0;  // faults, or the new generation
  std::uint64_t group = 0;  // ring group index at the time
};

class AcquisitionLoop {
 public:
  // `ring`, `digitizer` (prepared with settings.geometry), `galvo` (prepared) and `initial` must
  // outlive the loop. `initial` is the pattern scanned until another is offered.
  AcquisitionLoop(shm::RingWriter& ring, hal::Digitizer& digitizer, hal::GalvoOutput& galvo,
                  const scan::ScanPattern* initial, LoopSettings settings);
  AcquisitionLoop(const AcquisitionLoop&) = delete;
  AcquisitionLoop& operator=(const AcquisitionLoop&) = delete;
  ~AcquisitionLoop();

  // Locks memory when asked and starts the thread, which makes itself real-time, prefaults its
  // stack and waits, parked, for a run command. Returns what the real-time setup got.
  RealtimeOutcome start();
  // Parks (when streaming) and ends the thread. Idempotent.
  void stop() noexcept;

  // The supervisor's side. `cycle` > 0 numbers each run command, so that what the thread reports
  // is matched to the command it answers.
  void command_run(std::uint64_t cycle) noexcept;
  void command_park() noexcept;
  LoopReport report() const noexcept;
  // Emission verified on: the groups recorded meanwhile carry kStatusLaserOn.
  void set_emission_on(bool on) noexcept { emission_on_.store(on, std::memory_order_relaxed); }

  // The housekeeping side. A pattern for the same timing, alive until handed back by
  // take_retired(); false when the mailbox is full (a change is already pending).
  bool offer_pattern(const scan::ScanPattern* pattern) noexcept;
  const scan::ScanPattern* take_retired() noexcept;
  std::optional<LoopEvent> take_event() noexcept { return events_.pop(); }
  LoopCounters counters() const noexcept;
  // A snapshot (a copy) of the histogram the acquisition thread fills.
  LatencyHistogram wake_latency() const noexcept { return wake_latency_; }
  // The message of the last error that ended acquisition (empty when none).
  std::string failure() const;
  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
  // Sweep 0 of the current (or last) arming started at clock().start_ns().
  SweepClock clock() const noexcept;
  const LoopSettings& settings() const noexcept { return settings_; }

 private:
  void run() noexcept;
  void arm() noexcept;
  void acquire_one_group() noexcept;
  // The faults a group's own status shows (timeout, device lost, clock, missed triggers).
  std::uint32_t group_faults(const hal::GroupInfo& info) const noexcept;
  // Counts the group's generation time and lateness; kFaultDeadlineMisses once too many in a row
  // were late by this thread's fault (not the source's), else 0.
  std::uint32_t judge_timing(const hal::GroupInfo& info, const GroupTimes& times,
                             std::uint64_t begin_ns, std::uint64_t generated_ns) noexcept;
  // After a timely group went out: verification, the page-fault baseline, retired patterns.
  void after_publish(const hal::GroupInfo& info) noexcept;
  void park() noexcept;
  // Tops the DAC FIFO up to its target; `streaming`: note the fill it found as the margin.
  void feed(bool streaming) noexcept;
  const scan::ScanPattern* take_offered() noexcept;
  void retire(const scan::ScanPattern* pattern) noexcept;
  void post_fault(std::uint32_t faults) noexcept;
  void wait_for_park_command() noexcept;
  // Sleeps until `deadline_ns` in slices; false when the command changed meanwhile.
  bool sleep_until(std::uint64_t deadline_ns) noexcept;
  bool commanded_to_run() const noexcept;
  void beat() noexcept;
  void event(LoopEventKind kind, std::uint32_t value) noexcept;
  void fail(const char* what) noexcept;

  shm::RingWriter& ring_;
  hal::Digitizer& digitizer_;
  hal::GalvoOutput& galvo_;
  LoopSettings settings_;
  std::thread thread_;

  // Supervisor ↔ thread.
  std::atomic<std::uint64_t> run_cycle_{0};  // 0: park
  std::atomic<std::uint64_t> serving_cycle_{0};
  std::atomic<bool> streaming_{false};
  std::atomic<bool> verified_{false};
  std::atomic<std::uint32_t> faults_{0};
  std::atomic<std::uint64_t> heartbeat_ns_{0};
  std::atomic<bool> emission_on_{false};
  std::atomic<bool> quit_{false};
  std::atomic<std::uint64_t> clock_start_ns_{0};

  // Housekeeping ↔ thread.
  SpscQueue<const scan::ScanPattern*> offered_{4};
  SpscQueue<const scan::ScanPattern*> retired_{16};
  SpscQueue<LoopEvent> events_{256};
  std::atomic<bool> failed_{false};
  std::string failure_;  // written by the thread before failed_ (release)

  // The thread's own state.
  const scan::ScanPattern* current_;
  ScanSchedule schedule_;
  SweepClock clock_;
  std::uint32_t generation_ = 0;
  std::uint64_t next_volume_ = 0;
  std::uint64_t feed_target_ = 0;
  std::vector<hal::GalvoSample> feed_buffer_;
  std::size_t feed_pending_begin_ = 0;
  std::size_t feed_pending_end_ = 0;
  std::uint64_t underruns_at_arm_ = 0;
  std::uint32_t consecutive_misses_ = 0;
  bool simulator_behind_ = false;  // the last group came late from the digitizer
  bool deadline_faults_ = true;    // decided when the thread starts (see LoopSettings)
  std::uint64_t groups_this_cycle_ = 0;
  std::uint64_t last_group_sweep_ = 0;
  std::array<const scan::ScanPattern*, 16> retire_backlog_{};
  std::size_t retire_backlog_count_ = 0;

  struct AtomicCounters {
    std::atomic<std::uint64_t> groups_generated{0};
    std::atomic<std::uint64_t> groups_published{0};
    std::atomic<std::uint64_t> groups_dropped{0};
    std::atomic<std::uint64_t> deadline_misses{0};
    std::atomic<std::uint64_t> worst_lateness_ns{0};
    std::atomic<std::uint64_t> generation_ns_total{0};
    std::atomic<std::uint64_t> generation_ns_max{0};
    std::atomic<std::uint64_t> missed_sweeps{0};
    std::atomic<std::uint64_t> simulator_late_groups{0};
    std::atomic<std::uint64_t> simulator_worst_lateness_ns{0};
    std::atomic<std::uint64_t> arms{0};
    std::atomic<std::uint64_t> parks{0};
    std::atomic<std::uint64_t> scan_changes{0};
    std::atomic<std::uint32_t> scan_generation{0};
    std::atomic<std::uint32_t> scan_pattern_id{0};
    std::atomic<std::uint64_t> dac_fill_last{0};
    std::atomic<std::uint64_t> dac_fill_min{0};
    std::atomic<std::uint64_t> dac_underruns{0};
    std::atomic<std::uint64_t> page_faults{0};
    std::atomic<std::uint64_t> page_faults_baseline{0};
    std::atomic<bool> steady{false};
  };
  AtomicCounters counters_;
  LatencyHistogram wake_latency_;
};

}  // namespace ioct::rt
