#include "acquisition_loop.hpp"

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <exception>
#include <future>
#include <span>
#include <stdexcept>
#include <utility>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "safety_state_machine.hpp"
#include "slot_description.hpp"

namespace ioct::rt {
namespace {

constexpr std::size_t kFeedChunk = 4096;  // galvo samples computed per write()

timespec to_timespec(std::uint64_t ns) noexcept {
  return timespec{static_cast<time_t>(ns / 1'000'000'000u), static_cast<long>(ns % 1'000'000'000u)};
}

void sleep_absolute(std::uint64_t wake_ns) noexcept {
  const timespec wake = to_timespec(wake_ns);
  // Absolute: wake-up latency never accumulates. EINTR just returns early; callers loop.
  ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
}

// The slot payload as the digitizer's 16-bit words; the payload is page aligned.
std::span<std::uint16_t> sample_words(std::span<std::byte> payload) noexcept {
  return {reinterpret_cast<std::uint16_t*>(payload.data()), payload.size() / sizeof(std::uint16_t)};
}

// Single writer: a plain load and store.
template <typename T>
void add(std::atomic<T>& word, T value) noexcept {
  word.store(word.load(std::memory_order_relaxed) + value, std::memory_order_relaxed);
}
void store_max(std::atomic<std::uint64_t>& word, std::uint64_t value) noexcept {
  if (value > word.load(std::memory_order_relaxed)) word.store(value, std::memory_order_relaxed);
}

std::uint64_t thread_page_faults() noexcept {
  rusage usage{};
  ::getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_minflt) + static_cast<std::uint64_t>(usage.ru_majflt);
}

std::uint32_t galvo_faults(const hal::GalvoStatus& status,
                           std::uint64_t underruns_at_arm) noexcept {
  std::uint32_t faults = 0;
  if (status.underruns > underruns_at_arm || (status.faults & hal::kGalvoUnderrun) != 0) {
    faults |= kFaultGalvoUnderrun;
  }
  if ((status.faults & (hal::kGalvoDriverFault | hal::kGalvoDeviceLost)) != 0) {
    faults |= kFaultGalvoFault;
  }
  return faults;
}

// The sweep period of the loop's clock: the digitizer's, shortened by a faster replay.
double paced_sweep_period_ns(const LoopSettings& settings) noexcept {
  return settings.geometry.sweep_period_ns() / settings.pace_speed;
}

}  // namespace

AcquisitionLoop::AcquisitionLoop(shm::RingWriter& ring, hal::Digitizer& digitizer,
                                 hal::GalvoOutput& galvo, const scan::ScanPattern* initial,
                                 LoopSettings settings)
    : ring_(ring),
      digitizer_(digitizer),
      galvo_(galvo),
      settings_(settings),
      current_(initial),
      feed_buffer_(kFeedChunk) {
  if (initial == nullptr) throw std::invalid_argument("acquisition loop: no initial scan pattern");
  const std::uint64_t capacity = galvo_.config().fifo_capacity;
  feed_target_ = std::min<std::uint64_t>(
      capacity, std::uint64_t{settings_.feed_ahead_groups} * settings_.geometry.sweeps_per_group());
  clock_ = SweepClock(0, paced_sweep_period_ns(settings_));
}

AcquisitionLoop::~AcquisitionLoop() {
  stop();
}

RealtimeOutcome AcquisitionLoop::start() {
  if (thread_.joinable()) throw std::logic_error("acquisition loop: start() twice");
  RealtimeOutcome outcome;
  if (settings_.realtime.lock_memory) outcome.memory_lock_error = lock_process_memory();
  std::promise<RealtimeOutcome> ready;
  std::future<RealtimeOutcome> started = ready.get_future();
  heartbeat_ns_.store(ioct::monotonic_ns(), std::memory_order_relaxed);
  thread_ = std::thread([this, ready = std::move(ready), outcome]() mutable {
    make_current_thread_realtime(settings_.realtime, outcome);
    deadline_faults_ = settings_.deadline_faults_without_realtime ||
                       (settings_.realtime.fifo_priority > 0 && outcome.fifo_error == 0);
    prefault_stack(settings_.stack_prefault_bytes);
    ready.set_value(outcome);
    run();
  });
  return started.get();
}

void AcquisitionLoop::stop() noexcept {
  quit_.store(true, std::memory_order_seq_cst);
  if (thread_.joinable()) thread_.join();
}

void AcquisitionLoop::command_run(std::uint64_t cycle) noexcept {
  run_cycle_.store(cycle, std::memory_order_seq_cst);
}

void AcquisitionLoop::command_park() noexcept {
  run_cycle_.store(0, std::memory_order_seq_cst);
}

LoopReport AcquisitionLoop::report() const noexcept {
  LoopReport r;
  r.streaming = streaming_.load(std::memory_order_seq_cst);
  r.serving_cycle = serving_cycle_.load(std::memory_order_acquire);
  r.verified = verified_.load(std::memory_order_acquire);
  r.faults = faults_.load(std::memory_order_acquire);
  r.heartbeat_ns = heartbeat_ns_.load(std::memory_order_relaxed);
  return r;
}

bool AcquisitionLoop::offer_pattern(const scan::ScanPattern* pattern) noexcept {
  return pattern != nullptr && offered_.push(pattern);
}

const scan::ScanPattern* AcquisitionLoop::take_retired() noexcept {
  const std::optional<const scan::ScanPattern*> p = retired_.pop();
  return p ? *p : nullptr;
}

LoopCounters AcquisitionLoop::counters() const noexcept {
  const auto get = [](const auto& word) { return word.load(std::memory_order_relaxed); };
  const AtomicCounters& c = counters_;
  LoopCounters out;
  out.groups_generated = get(c.groups_generated);
  out.groups_published = get(c.groups_published);
  out.groups_dropped = get(c.groups_dropped);
  out.deadline_misses = get(c.deadline_misses);
  out.worst_lateness_ns = get(c.worst_lateness_ns);
  out.generation_ns_total = get(c.generation_ns_total);
  out.generation_ns_max = get(c.generation_ns_max);
  out.missed_sweeps = get(c.missed_sweeps);
  out.simulator_late_groups = get(c.simulator_late_groups);
  out.simulator_worst_lateness_ns = get(c.simulator_worst_lateness_ns);
  out.arms = get(c.arms);
  out.parks = get(c.parks);
  out.scan_changes = get(c.scan_changes);
  out.scan_generation = get(c.scan_generation);
  out.scan_pattern_id = get(c.scan_pattern_id);
  out.dac_fill_last = get(c.dac_fill_last);
  out.dac_fill_min = get(c.dac_fill_min);
  out.dac_underruns = get(c.dac_underruns);
  out.page_faults = get(c.page_faults);
  out.page_faults_steady = get(c.steady) ? out.page_faults - get(c.page_faults_baseline) : 0;
  return out;
}

std::string AcquisitionLoop::failure() const {
  return failed() ? failure_ : std::string();
}

SweepClock AcquisitionLoop::clock() const noexcept {
  return SweepClock(clock_start_ns_.load(std::memory_order_acquire),
                    paced_sweep_period_ns(settings_));
}

bool AcquisitionLoop::commanded_to_run() const noexcept {
  return !quit_.load(std::memory_order_relaxed) &&
         run_cycle_.load(std::memory_order_seq_cst) ==
             serving_cycle_.load(std::memory_order_relaxed);
}

void AcquisitionLoop::beat() noexcept {
  heartbeat_ns_.store(ioct::monotonic_ns(), std::memory_order_relaxed);
}

void AcquisitionLoop::event(LoopEventKind kind, std::uint32_t value) noexcept {
  // A full queue (housekeeping stalled) loses the event, never blocks the thread.
  static_cast<void>(events_.push(LoopEvent{ioct::monotonic_ns(), kind, value, ring_.published()}));
}

void AcquisitionLoop::fail(const char* what) noexcept {
  if (!failed_.load(std::memory_order_relaxed)) {
    try {
      failure_ = what;
    } catch (...) {
    }
    failed_.store(true, std::memory_order_release);
  }
}

void AcquisitionLoop::run() noexcept {
  while (!quit_.load(std::memory_order_relaxed)) {
    beat();
    if (!streaming_.load(std::memory_order_relaxed)) {
      // A run command is served once: after parking on its own (a fault) the thread waits for
      // a new one rather than re-arming under the old.
      const std::uint64_t cycle = run_cycle_.load(std::memory_order_seq_cst);
      if (cycle != 0 && cycle != serving_cycle_.load(std::memory_order_relaxed)) {
        arm();
      } else {
        sleep_absolute(ioct::monotonic_ns() + settings_.check_interval_ns);
      }
      continue;
    }
    if (!commanded_to_run()) {
      park();
      continue;
    }
    acquire_one_group();
  }
  if (streaming_.load(std::memory_order_relaxed)) park();
}

const scan::ScanPattern* AcquisitionLoop::take_offered() noexcept {
  const scan::ScanPattern* newest = nullptr;
  while (const std::optional<const scan::ScanPattern*> p = offered_.pop()) {
    if (newest != nullptr) retire(newest);  // superseded before it was ever scanned
    newest = *p;
  }
  return newest;
}

void AcquisitionLoop::retire(const scan::ScanPattern* pattern) noexcept {
  // Flush the backlog first so patterns come back in order.
  while (retire_backlog_count_ > 0 && retired_.push(retire_backlog_[0])) {
    std::copy(retire_backlog_.begin() + 1, retire_backlog_.begin() + retire_backlog_count_,
              retire_backlog_.begin());
    --retire_backlog_count_;
  }
  if (pattern == nullptr) return;
  if (retire_backlog_count_ == 0 && retired_.push(pattern)) return;
  // Housekeeping is behind: keep it; if even the backlog is full, the pattern stays allocated
  // until the process ends (never freed here: this thread does not free).
  if (retire_backlog_count_ < retire_backlog_.size())
    retire_backlog_[retire_backlog_count_++] = pattern;
}

void AcquisitionLoop::arm() noexcept {
  const std::uint64_t cycle = run_cycle_.load(std::memory_order_seq_cst);
  if (cycle == 0) return;
  faults_.store(0, std::memory_order_relaxed);
  verified_.store(false, std::memory_order_relaxed);
  serving_cycle_.store(cycle, std::memory_order_release);
  streaming_.store(true, std::memory_order_seq_cst);
  // Paired with the supervisor's command store and its later streaming load: either it sees
  // this thread streaming, or this thread sees its park.
  if (run_cycle_.load(std::memory_order_seq_cst) != cycle) {
    streaming_.store(false, std::memory_order_seq_cst);
    return;
  }

  if (const scan::ScanPattern* offered = take_offered()) {
    retire(current_);
    current_ = offered;
    add(counters_.scan_changes, std::uint64_t{1});
  }
  ++generation_;
  schedule_.reset(current_, generation_, next_volume_, settings_.geometry.sweeps_per_group(),
                  settings_.galvo_lead_samples);
  feed_pending_begin_ = feed_pending_end_ = 0;
  consecutive_misses_ = 0;
  simulator_behind_ = false;
  groups_this_cycle_ = 0;
  last_group_sweep_ = 0;
  counters_.scan_generation.store(generation_, std::memory_order_relaxed);
  counters_.scan_pattern_id.store(current_->pattern_id(), std::memory_order_relaxed);
  counters_.dac_fill_min.store(feed_target_, std::memory_order_relaxed);
  counters_.dac_underruns.store(0, std::memory_order_relaxed);

  try {
    feed(false);         // prefill, so the stream starts with the scan queued
    galvo_.start();      // followers first ...
    digitizer_.start();  // ... the trigger last
  } catch (const std::exception& e) {
    fail(e.what());
    post_fault(kFaultStartFailed);
    wait_for_park_command();
    park();
    return;
  }
  const std::uint64_t now = ioct::monotonic_ns();
  clock_ = SweepClock(now, paced_sweep_period_ns(settings_));
  clock_start_ns_.store(now, std::memory_order_release);
  underruns_at_arm_ = galvo_.status().underruns;
  add(counters_.arms, std::uint64_t{1});
  event(LoopEventKind::armed, generation_);
}

void AcquisitionLoop::feed(bool streaming) noexcept {
  const hal::GalvoStatus status = galvo_.status();
  const std::uint64_t fill = status.fifo_fill;
  if (streaming) {  // the margin the stream had left; the prefill before start has none to show
    counters_.dac_fill_last.store(fill, std::memory_order_relaxed);
    if (fill < counters_.dac_fill_min.load(std::memory_order_relaxed)) {
      counters_.dac_fill_min.store(fill, std::memory_order_relaxed);
    }
  }
  std::uint64_t wanted = fill < feed_target_ ? feed_target_ - fill : 0;
  const auto offer = [this]() -> const scan::ScanPattern* {
    const scan::ScanPattern* next = take_offered();
    if (next != nullptr) {
      add(counters_.scan_changes, std::uint64_t{1});
      event(LoopEventKind::scan_changed, schedule_.newest().generation + 1);
    }
    return next;
  };
  while (wanted > 0) {
    if (feed_pending_begin_ == feed_pending_end_) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(wanted, kFeedChunk));
      for (std::size_t i = 0; i < n; ++i) feed_buffer_[i] = schedule_.next_position(offer);
      feed_pending_begin_ = 0;
      feed_pending_end_ = n;
    }
    const std::span<const hal::GalvoSample> pending(feed_buffer_.data() + feed_pending_begin_,
                                                    feed_pending_end_ - feed_pending_begin_);
    const std::size_t written = galvo_.write(pending);
    feed_pending_begin_ += written;
    wanted -= std::min<std::uint64_t>(wanted, written);
    if (written < pending.size()) break;  // the FIFO is full: the rest waits for next time
  }
  generation_ = schedule_.newest().generation;
}

void AcquisitionLoop::post_fault(std::uint32_t faults) noexcept {
  faults_.fetch_or(faults, std::memory_order_acq_rel);
  event(LoopEventKind::fault, faults);
}

void AcquisitionLoop::wait_for_park_command() noexcept {
  const std::uint64_t give_up = ioct::monotonic_ns() + settings_.park_wait_ns;
  while (commanded_to_run() && ioct::monotonic_ns() < give_up) {
    beat();
    sleep_absolute(std::min(give_up, ioct::monotonic_ns() + settings_.check_interval_ns / 4));
  }
}

bool AcquisitionLoop::sleep_until(std::uint64_t deadline_ns) noexcept {
  for (;;) {
    beat();
    if (!commanded_to_run()) return false;
    const std::uint64_t now = ioct::monotonic_ns();
    if (now >= deadline_ns) return true;
    sleep_absolute(std::min(deadline_ns, now + settings_.check_interval_ns));
  }
}

void AcquisitionLoop::park() noexcept {
  galvo_.park();  // the mirrors to their rest position, the stream dropped
  digitizer_.stop();
  verified_.store(false, std::memory_order_relaxed);
  // The next arming continues the volume count and scans the newest pattern.
  next_volume_ = schedule_.volume_at(last_group_sweep_) + 1;
  current_ = schedule_.newest().pattern;
  std::array<const scan::ScanPattern*, ScanSchedule::kMaxEntries> retired{};
  const std::size_t n = schedule_.retire_before(schedule_.newest().first_sweep, retired);
  for (std::size_t i = 0; i < n; ++i) retire(retired[i]);
  add(counters_.parks, std::uint64_t{1});
  streaming_.store(false, std::memory_order_seq_cst);
  event(LoopEventKind::parked, faults_.load(std::memory_order_relaxed));
}

void AcquisitionLoop::acquire_one_group() noexcept {
  const hal::DigitizerConfig& geometry = settings_.geometry;
  feed(true);
  const hal::GalvoStatus galvo = galvo_.status();
  counters_.dac_underruns.store(galvo.underruns - underruns_at_arm_, std::memory_order_relaxed);
  std::uint32_t faults = galvo_faults(galvo, underruns_at_arm_);
  const bool laser_at_start = emission_on_.load(std::memory_order_relaxed);

  const shm::RingWriter::Claim claim = ring_.claim();
  const std::uint64_t begin_ns = ioct::monotonic_ns();
  hal::GroupInfo info;
  try {
    digitizer_.acquire_group(sample_words(claim.payload), info);
  } catch (const std::exception& e) {
    fail(e.what());
    add(counters_.groups_dropped, std::uint64_t{1});
    post_fault(kFaultAcquisitionFailed | faults);
    wait_for_park_command();
    park();
    return;
  }
  const std::uint64_t generated_ns = ioct::monotonic_ns();
  beat();
  last_group_sweep_ = info.first_sweep_counter;

  faults |= group_faults(info);
  const bool complete = (info.status & (hal::kGroupTimeout | hal::kGroupDeviceLost)) == 0;
  const GroupTimes times = group_times(clock_, geometry, info.first_sweep_counter);
  faults |= judge_timing(info, times, begin_ns, generated_ns);

  if (faults != 0) {
    post_fault(faults);
    if (complete) {
      // Recorded data: published with its flags, so nothing recorded is lost.
      describe_group(
          *claim.header, info, times, geometry, schedule_.at(info.first_sweep_counter),
          settings_.extra_status |
              (faults & (kFaultGalvoFault | kFaultGalvoUnderrun) ? shm::kStatusGalvoFault : 0u));
      ring_.publish(claim);
      add(counters_.groups_published, std::uint64_t{1});
    } else {
      add(counters_.groups_dropped, std::uint64_t{1});
    }
    wait_for_park_command();
    park();
    return;
  }

  // A simulated group is ready early and waits for its last sweep to end.
  if (generated_ns < times.complete_ns && !sleep_until(times.complete_ns)) {
    add(counters_.groups_dropped, std::uint64_t{1});  // parked meanwhile
    return;
  }
  const std::uint64_t resumed_ns = ioct::monotonic_ns();
  wake_latency_.record(resumed_ns > times.complete_ns ? resumed_ns - times.complete_ns : 0);

  const bool laser_on = laser_at_start && emission_on_.load(std::memory_order_relaxed);
  describe_group(*claim.header, info, times, geometry, schedule_.at(info.first_sweep_counter),
                 settings_.extra_status | (laser_on ? shm::kStatusLaserOn : 0u));
  ring_.publish(claim);
  add(counters_.groups_published, std::uint64_t{1});
  ++groups_this_cycle_;
  after_publish(info);
}

std::uint32_t AcquisitionLoop::group_faults(const hal::GroupInfo& info) const noexcept {
  std::uint32_t faults = 0;
  if ((info.status & hal::kGroupTimeout) != 0) faults |= kFaultDigitizerTimeout;
  if ((info.status & hal::kGroupDeviceLost) != 0) faults |= kFaultDigitizerLost;
  if ((info.status & hal::kGroupClockFault) != 0) faults |= kFaultClockLost;
  if (info.missed_sweeps > settings_.max_missed_sweeps_per_group) faults |= kFaultTriggerLost;
  return faults;
}

std::uint32_t AcquisitionLoop::judge_timing(const hal::GroupInfo& info, const GroupTimes& times,
                                            std::uint64_t begin_ns,
                                            std::uint64_t generated_ns) noexcept {
  add(counters_.groups_generated, std::uint64_t{1});
  add(counters_.generation_ns_total, generated_ns - begin_ns);
  store_max(counters_.generation_ns_max, generated_ns - begin_ns);
  add(counters_.missed_sweeps, std::uint64_t{info.missed_sweeps});

  // The source was behind, not this thread: counted apart, and no reason to fault.
  const bool source_late = (info.status & hal::kGroupLate) != 0;
  if (source_late) {
    const std::uint64_t lateness =
        generated_ns > times.complete_ns ? generated_ns - times.complete_ns : 0;
    add(counters_.simulator_late_groups, std::uint64_t{1});
    store_max(counters_.simulator_worst_lateness_ns, lateness);
    if (!simulator_behind_) {
      event(LoopEventKind::simulator_behind,
            static_cast<std::uint32_t>(std::min<std::uint64_t>(lateness / 1000, 0xFFFFFFFFu)));
    }
  }
  simulator_behind_ = source_late;

  const std::uint64_t deadline_ns = times.complete_ns + settings_.publish_slack_ns;
  if (source_late || generated_ns <= deadline_ns) {
    consecutive_misses_ = 0;
    return 0;
  }
  add(counters_.deadline_misses, std::uint64_t{1});
  store_max(counters_.worst_lateness_ns, generated_ns - deadline_ns);
  return ++consecutive_misses_ > settings_.max_consecutive_misses && deadline_faults_
             ? kFaultDeadlineMisses
             : 0u;
}

void AcquisitionLoop::after_publish(const hal::GroupInfo& info) noexcept {
  if (!verified_.load(std::memory_order_relaxed)) {
    // Verified: a complete, timely group is out and the mirrors are being driven.
    const hal::GalvoStatus now = galvo_.status();
    if (now.samples_output > 0 && galvo_faults(now, underruns_at_arm_) == 0) {
      verified_.store(true, std::memory_order_release);
    }
  }
  const std::uint64_t page_faults = thread_page_faults();
  counters_.page_faults.store(page_faults, std::memory_order_relaxed);
  if (!counters_.steady.load(std::memory_order_relaxed) &&
      groups_this_cycle_ >= ring_.layout().slot_count) {
    counters_.page_faults_baseline.store(page_faults, std::memory_order_relaxed);
    counters_.steady.store(true, std::memory_order_relaxed);
  }
  std::array<const scan::ScanPattern*, ScanSchedule::kMaxEntries> retired{};
  const std::size_t n = schedule_.retire_before(info.first_sweep_counter, retired);
  for (std::size_t i = 0; i < n; ++i) retire(retired[i]);
  if (retire_backlog_count_ > 0) retire(nullptr);
  counters_.scan_generation.store(schedule_.at(info.first_sweep_counter).generation,
                                  std::memory_order_relaxed);
  counters_.scan_pattern_id.store(schedule_.at(info.first_sweep_counter).pattern->pattern_id(),
                                  std::memory_order_relaxed);
}

}  // namespace ioct::rt
