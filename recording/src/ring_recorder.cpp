#include "ioct/ringrec/ring_recorder.hpp"

#include <sys/statvfs.h>

#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "ioct/common/config_error.hpp"
#include "ioct/ringrec/group_queue.hpp"
#include "ioct/ringrec/ring_recording_writer.hpp"
#include "ioct/shm/monotonic_clock.hpp"
#include "ioct/shm/ring_attach.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::ringrec {
namespace {

constexpr std::uint64_t kNsPerS = 1'000'000'000;
constexpr int kWriterWakeMs = 200;  // the writer refreshes the file's counters this often idle

std::uint64_t seconds_to_ns(double seconds) {
  return static_cast<std::uint64_t>(seconds * 1e9);
}

// Counters both threads add to; snapshot() is what goes into the file.
class SharedCounters {
 public:
  void add(Counter counter, std::uint64_t n = 1) noexcept {
    values_[static_cast<std::size_t>(counter)].fetch_add(n, std::memory_order_relaxed);
  }
  std::uint64_t get(Counter counter) const noexcept {
    return values_[static_cast<std::size_t>(counter)].load(std::memory_order_relaxed);
  }
  CounterValues snapshot() const noexcept {
    CounterValues out{};
    for (std::size_t i = 0; i < kCounterCount; ++i) {
      out[i] = values_[i].load(std::memory_order_relaxed);
    }
    return out;
  }

 private:
  std::array<std::atomic<std::uint64_t>, kCounterCount> values_{};
};

// Whether the next group fits: under --max-bytes, and leaving reserve_bytes free on the file
// system (statvfs of the file's directory). Checked before each group, so a full disk shows as
// dropped groups and a file that stays intact, not as a write failing halfway.
class RoomCheck {
 public:
  RoomCheck(const RecorderConfig& config)
      : directory_(config.out.has_parent_path() ? config.out.parent_path() : "."),
        max_bytes_(config.max_bytes),
        reserve_bytes_(config.reserve_bytes) {}

  // Empty when there is room; else why not.
  std::string refuse(std::uint64_t written, std::uint64_t next) const {
    if (max_bytes_ != 0 && written + next > max_bytes_) {
      return "the recording reached --max-bytes " + std::to_string(max_bytes_) + " (" +
             std::to_string(written) + " bytes written, a group needs " + std::to_string(next) +
             ")";
    }
    struct statvfs fs {};
    if (::statvfs(directory_.c_str(), &fs) == 0) {
      const std::uint64_t free_bytes = std::uint64_t{fs.f_bavail} * fs.f_frsize;
      if (free_bytes < next + reserve_bytes_) {
        return "disk full: " + std::to_string(free_bytes) + " bytes free on the file system of " +
               directory_.string() + ", a group needs " + std::to_string(next) + " (+ " +
               std::to_string(reserve_bytes_) + " kept free)";
      }
    }
    return {};
  }

 private:
  std::filesystem::path directory_;
  std::uint64_t max_bytes_;
  std::uint64_t reserve_bytes_;
};

// The writer thread's state; only this thread touches the HDF5 file once it runs.
struct DiskWriter {
  DiskWriter(RingRecordingWriter& file_, GroupQueue& queue_, SharedCounters& counters_,
             RoomCheck room_, std::ostream* status_, std::mutex* status_mutex_)
      : file(file_),
        queue(queue_),
        counters(counters_),
        room(std::move(room_)),
        status(status_),
        status_mutex(status_mutex_) {}

  RingRecordingWriter& file;
  GroupQueue& queue;
  SharedCounters& counters;
  RoomCheck room;
  std::ostream* status;
  std::mutex* status_mutex;
  std::atomic<bool> failed{false};
  std::string failure;  // read after join
  std::uint64_t busy_ns = 0;

  void say(const std::string& line) {
    if (status == nullptr) return;
    std::lock_guard lock(*status_mutex);
    *status << "ioct-record: " << line << std::endl;
  }

  void run() {
    bool refusing = false;
    try {
      for (;;) {
        const std::optional<std::size_t> index = queue.pop_filled(kWriterWakeMs);
        if (!index) {
          if (queue.closed_and_drained()) break;
          file.write_counters(counters.snapshot());
          continue;
        }
        GroupBuffer& buffer = queue.buffer(*index);
        const std::uint64_t bytes = buffer.payload.size() + sizeof(shm::SlotHeader);
        const std::string refusal = room.refuse(counters.get(Counter::bytes_written), bytes);
        if (!refusal.empty()) {
          counters.add(Counter::dropped_disk_full);
          if (!refusing) say(refusal + ": dropping groups, counted as dropped_disk_full");
          refusing = true;
        } else {
          if (refusing) say("room again: recording resumes");
          refusing = false;
          const std::uint64_t start = shm::monotonic_ns();
          file.append(buffer.header, buffer.payload);
          CounterValues next = counters.snapshot();
          next[static_cast<std::size_t>(Counter::groups_written)] += 1;
          next[static_cast<std::size_t>(Counter::bytes_written)] += bytes;
          file.write_counters(next);  // flushes: the group is in the file from here on
          // Counted only now, so a status line never counts a group a kill could still lose.
          counters.add(Counter::groups_written);
          counters.add(Counter::bytes_written, bytes);
          busy_ns += shm::monotonic_ns() - start;
        }
        queue.release(*index);
      }
    } catch (const std::exception& e) {
      failure = e.what();
      failed.store(true, std::memory_order_release);
      // Nothing more is written; free every queued buffer so the reader keeps counting.
      while (const std::optional<std::size_t> index = queue.pop_filled(0)) {
        counters.add(Counter::dropped_disk_full);
        queue.release(*index);
      }
    }
  }
};

void print_status(std::ostream& out, std::mutex& mutex, const SharedCounters& counters,
                  double seconds, std::uint64_t bytes_before, double interval_s, std::size_t queued,
                  std::size_t capacity) {
  const CounterValues c = counters.snapshot();
  auto at = [&](Counter k) { return c[static_cast<std::size_t>(k)]; };
  char line[320];
  std::snprintf(line, sizeof line,
                "%.1f s: %llu groups written (%.1f MB/s), lost: lapped %llu, behind %llu, "
                "queue full %llu, disk full %llu; queue %zu/%zu",
                seconds, static_cast<unsigned long long>(at(Counter::groups_written)),
                interval_s > 0 ? static_cast<double>(at(Counter::bytes_written) - bytes_before) /
                                     interval_s * 1e-6
                               : 0.0,
                static_cast<unsigned long long>(at(Counter::dropped_lapped)),
                static_cast<unsigned long long>(at(Counter::dropped_behind)),
                static_cast<unsigned long long>(at(Counter::dropped_queue_full)),
                static_cast<unsigned long long>(at(Counter::dropped_disk_full)), queued, capacity);
  std::lock_guard lock(mutex);
  out << "ioct-record: " << line << std::endl;
}

}  // namespace

void RecorderConfig::validate() const {
  const bool plain = !ring_name.empty() && ring_name.find('/') == std::string::npos;
  const bool path = ring_name.size() > 1 && ring_name.front() == '/' && ring_name.back() != '/';
  if (!plain && !path) {
    throw ConfigError("ring", "'" + ring_name + "'",
                      "must be a shared-memory name without '/' or an absolute path");
  }
  if (out.empty()) throw ConfigError("out", "''", "must name the recording file to write");
  require_real_in_range("seconds", run_s, 0.0, 1e9);
  require_real_in_range("wait", wait_s, 0.0, 1e6);
  require_integer_in_range("queue_groups", queue_groups, 1, 4096);
  require_real_in_range("status_interval", status_interval_s, 0.0, 1e6);
  require_real_in_range("poll_interval", poll_interval_s, 1e-6, 1.0);
  if (label.empty() || label.size() >= shm::kReaderLabelBytes) {
    throw ConfigError("label", "'" + label + "'",
                      "must be 1 to " + std::to_string(shm::kReaderLabelBytes - 1) + " characters");
  }
}

RingRecorder::RingRecorder(RecorderConfig config) : config_(std::move(config)) {
  config_.validate();
}

RecorderSummary RingRecorder::run(std::ostream* status) {
  std::mutex status_mutex;
  auto say = [&](const std::string& line) {
    if (status == nullptr) return;
    std::lock_guard lock(status_mutex);
    *status << "ioct-record: " << line << std::endl;
  };

  shm::AttachWait first_wait;
  first_wait.deadline_ns = shm::monotonic_ns() + seconds_to_ns(config_.wait_s);
  first_wait.stop = &stop_;
  std::optional<shm::RingReader> reader = shm::attach_when_available(
      config_.ring_name, shm::ReaderOptions{config_.label}, first_wait, config_.wait_s);
  RecorderSummary summary;
  if (!reader) {
    summary.stop_reason = "stopped before the ring was readable";
    return summary;
  }
  const shm::RingGeometry geometry = reader->geometry();

  RecordingDescription description;
  description.geometry = geometry;
  description.ring_name = config_.ring_name;
  description.producer = config_.producer;
  description.run_metadata = config_.run_metadata;
  RingRecordingWriter file(config_.out, description, config_.overwrite);
  GroupQueue queue(config_.queue_groups, reader->layout().group_payload_bytes);
  SharedCounters counters;
  DiskWriter writer(file, queue, counters, RoomCheck(config_), status, &status_mutex);
  say("recording ring '" + config_.ring_name + "' into " + config_.out.string());
  std::thread writer_thread([&writer] { writer.run(); });

  // Reader counters of the attachments before this one (each attachment starts from zero).
  shm::ReaderCounters earlier{};
  auto add_reader_counters = [&](const shm::ReaderCounters& now, shm::ReaderCounters& seen) {
    counters.add(Counter::dropped_lapped, now.dropped_lapped - seen.dropped_lapped);
    counters.add(Counter::dropped_behind, now.dropped_behind - seen.dropped_behind);
    counters.add(Counter::producer_restarts, now.epoch_changes - seen.epoch_changes);
    seen = now;
  };

  const std::uint64_t start = shm::monotonic_ns();
  const std::uint64_t end = config_.run_s > 0 ? start + seconds_to_ns(config_.run_s) : UINT64_MAX;
  const std::uint64_t status_ns = seconds_to_ns(config_.status_interval_s);
  const std::uint64_t poll_ns = seconds_to_ns(config_.poll_interval_s);
  std::uint64_t next_status = start + status_ns;
  std::uint64_t bytes_at_last_status = 0;
  summary.stop_reason = "stopped";
  for (;;) {
    const std::uint64_t now = shm::monotonic_ns();
    if (stop_.load(std::memory_order_relaxed)) break;
    if (now >= end) {
      summary.stop_reason = "time limit";
      break;
    }
    if (writer.failed.load(std::memory_order_acquire)) break;
    if (status != nullptr && status_ns > 0 && now >= next_status) {
      print_status(*status, status_mutex, counters, static_cast<double>(now - start) / kNsPerS,
                   bytes_at_last_status, config_.status_interval_s, queue.queued(),
                   queue.capacity());
      bytes_at_last_status = counters.get(Counter::bytes_written);
      next_status = now + status_ns;
    }
    shm::ReadTicket ticket;
    const shm::PollStatus poll = reader->begin_read(ticket);
    if (poll == shm::PollStatus::ready) {
      if (const std::optional<std::size_t> index = queue.try_take_free()) {
        GroupBuffer& buffer = queue.buffer(*index);
        shm::seqlock_copy(buffer.payload.data(), ticket.payload, ticket.payload_bytes);
        buffer.header = ticket.header;
        if (reader->end_read(ticket)) {
          queue.push_filled(*index);
        } else {
          queue.give_back_free(*index);
        }
      } else if (reader->end_read(ticket)) {
        counters.add(Counter::dropped_queue_full);  // intact, but no room to keep it
      }
      add_reader_counters(reader->counters(), earlier);
      continue;
    }
    add_reader_counters(reader->counters(), earlier);
    if (poll == shm::PollStatus::empty) {
      reader->heartbeat();
      std::this_thread::sleep_for(std::chrono::nanoseconds(poll_ns));
      continue;
    }
    // producer_gone: every group it published has been read.
    if (config_.exit_when_producer_gone) {
      summary.stop_reason = "producer gone";
      break;
    }
    reader.reset();
    earlier = {};
    say("producer gone (ring '" + config_.ring_name + "' closed or replaced): waiting for it");
    shm::AttachWait again;
    again.unbounded = true;
    again.stop = &stop_;
    again.report_interval_ns = status != nullptr ? status_ns : 0;
    again.on_waiting = [&](shm::RingErrc last, std::uint64_t waited_ns) {
      char line[128];
      std::snprintf(line, sizeof line, "waiting for the producer for %.0f s: %s",
                    static_cast<double>(waited_ns) / kNsPerS,
                    std::string(shm::to_string(last)).c_str());
      say(line);
    };
    reader =
        shm::attach_when_available(config_.ring_name, shm::ReaderOptions{config_.label}, again);
    if (!reader) break;  // stopped while waiting
    if (!(reader->geometry() == geometry)) {
      const shm::RingGeometry& g = reader->geometry();
      summary.stop_reason = "the producer came back with another geometry (" +
                            std::to_string(g.samples_per_ascan) + " samples x " +
                            std::to_string(g.ascans_per_bscan) + " A-scans x " +
                            std::to_string(g.bscans_per_group) + " B-scans; the recording has " +
                            std::to_string(geometry.samples_per_ascan) + " x " +
                            std::to_string(geometry.ascans_per_bscan) + " x " +
                            std::to_string(geometry.bscans_per_group) + "): start a new recording";
      summary.failed = true;
      break;
    }
    counters.add(Counter::producer_restarts);
    say("producer back: recording goes on");
  }
  summary.seconds = static_cast<double>(shm::monotonic_ns() - start) / kNsPerS;
  queue.close();
  writer_thread.join();
  if (writer.failed.load(std::memory_order_acquire)) {
    summary.failed = true;
    summary.stop_reason = "writing failed: " + writer.failure;
  }
  summary.counters = counters.snapshot();
  summary.counters[static_cast<std::size_t>(Counter::finished)] = 1;
  if (writer.busy_ns > 0) {
    summary.write_mb_per_s =
        static_cast<double>(summary.counters[static_cast<std::size_t>(Counter::bytes_written)]) /
        (static_cast<double>(writer.busy_ns) * 1e-9) * 1e-6;
  }
  try {
    file.close(summary.counters);
  } catch (const std::exception& e) {
    summary.failed = true;
    summary.stop_reason = std::string("closing the file failed: ") + e.what();
  }
  return summary;
}

}  // namespace ioct::ringrec
