#include "ioct/ringrec/ring_recorder.hpp"

#include <sys/statvfs.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/ringrec/group_queue.hpp"
#include "ioct/ringrec/ring_recording_writer.hpp"
#include "ioct/shm/ring_attach.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::ringrec {
namespace {

constexpr std::uint64_t kNsPerS = 1'000'000'000;
constexpr int kWriterWakeMs = 200;  // the writer refreshes the file's counters this often idle

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
  RoomCheck(const RecorderConfig& config, const std::filesystem::path& file)
      : directory_(file.has_parent_path() ? file.parent_path() : "."),
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

// A status line, where the recorder was given a log.
void say(const Log* log, const std::string& line) {
  if (log != nullptr) log->info(line);
}

// The writer thread's state; only this thread touches the HDF5 file once it runs.
struct DiskWriter {
  DiskWriter(RingRecordingWriter& file_, GroupQueue& queue_, SharedCounters& counters_,
             RoomCheck room_, const Log* log_)
      : file(file_), queue(queue_), counters(counters_), room(std::move(room_)), log(log_) {}

  RingRecordingWriter& file;
  GroupQueue& queue;
  SharedCounters& counters;
  RoomCheck room;
  const Log* log;
  std::atomic<bool> failed{false};
  std::string failure;  // read after join
  std::uint64_t busy_ns = 0;

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
          if (!refusing) say(log, refusal + ": dropping groups, counted as dropped_disk_full");
          refusing = true;
        } else {
          if (refusing) say(log, "room again: recording resumes");
          refusing = false;
          const std::uint64_t start = ioct::monotonic_ns();
          file.append(buffer.header, buffer.payload);
          CounterValues next = counters.snapshot();
          next[static_cast<std::size_t>(Counter::groups_written)] += 1;
          next[static_cast<std::size_t>(Counter::bytes_written)] += bytes;
          file.write_counters(next);  // flushes: the group is in the file from here on
          // Counted only now, so a status line never counts a group a kill could still lose.
          counters.add(Counter::groups_written);
          counters.add(Counter::bytes_written, bytes);
          busy_ns += ioct::monotonic_ns() - start;
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

void print_status(const Log& log, const SharedCounters& counters, double seconds,
                  std::uint64_t bytes_before, double interval_s, std::size_t queued,
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
  log.info(line);
}

}  // namespace

// One recording: its file, queue, counters and writer thread.
struct RingRecorder::Session {
  Session(const RecorderConfig& config, const std::filesystem::path& path,
          const RecordingDescription& description, bool overwrite, std::uint64_t group_bytes,
          const Log* log)
      : file_path(path),
        file(path, description, overwrite),
        queue(std::make_shared<GroupQueue>(config.queue_groups, group_bytes)),
        counters(std::make_shared<SharedCounters>()),
        writer(file, *queue, *counters, RoomCheck(config, path), log) {}

  std::filesystem::path file_path;
  RingRecordingWriter file;
  std::shared_ptr<GroupQueue> queue;
  std::shared_ptr<SharedCounters> counters;
  DiskWriter writer;
  std::thread writer_thread;
  std::uint64_t start_ns = 0;
  std::uint64_t end_ns = UINT64_MAX;
  double limit_s = 0.0;
  std::uint64_t next_status_ns = 0;
  std::uint64_t bytes_at_last_status = 0;
};

// What status() may read of the session under way from another thread: no HDF5 object in it.
struct RingRecorder::SessionView {
  std::filesystem::path file;
  std::shared_ptr<GroupQueue> queue;
  std::shared_ptr<const SharedCounters> counters;
  std::uint64_t start_ns = 0;
  double limit_s = 0.0;
};

std::filesystem::path recording_file(const std::filesystem::path& directory,
                                     const std::string& name) {
  const std::string shown = "'" + quote_input(name, 60) + "'";
  if (name.empty()) throw ConfigError("name", shown, "must not be empty");
  if (name.size() > kMaxRecordingNameBytes) {
    throw ConfigError("name", shown,
                      "must be at most " + std::to_string(kMaxRecordingNameBytes) + " bytes");
  }
  for (const char c : name) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '/' || c == '\\') {
      throw ConfigError("name", shown,
                        "must be a file name without a path separator: recordings go into the "
                        "--out directory");
    }
    if (byte < 0x20 || byte == 0x7f) {
      throw ConfigError("name", shown, "must not contain control bytes");
    }
  }
  if (name.find_first_not_of('.') == std::string::npos) {
    throw ConfigError("name", shown, "must not be only dots");
  }
  const bool has_suffix = name.size() > 3 && name.compare(name.size() - 3, 3, ".h5") == 0;
  const std::string file = has_suffix ? name : name + ".h5";
  if (file.size() > kMaxRecordingNameBytes) {
    throw ConfigError(
        "name", shown,
        "must be at most " + std::to_string(kMaxRecordingNameBytes) + " bytes with its .h5");
  }
  return directory / file;
}

void RecorderConfig::validate() const {
  const bool plain = !ring_name.empty() && ring_name.find('/') == std::string::npos;
  const bool path = ring_name.size() > 1 && ring_name.front() == '/' && ring_name.back() != '/';
  if (!plain && !path) {
    throw ConfigError("ring", "'" + ring_name + "'",
                      "must be a shared-memory name without '/' or an absolute path");
  }
  if (out.empty()) {
    throw ConfigError("out", "''",
                      standby ? "must name the directory the recordings go into"
                              : "must name the recording file to write");
  }
  if (standby) {
    std::error_code error;
    if (!std::filesystem::is_directory(out, error)) {
      throw ConfigError("out", "'" + out.string() + "'",
                        "must be an existing directory in standby (recordings go into it)");
    }
    if (run_s != 0.0) {
      throw ConfigError("seconds", format_value(run_s),
                        "is not for standby: give each recording's seconds to record-start");
    }
  }
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

std::unique_ptr<RingRecorder::Session> RingRecorder::open_session(const std::filesystem::path& file,
                                                                  double seconds, bool overwrite,
                                                                  const shm::RingGeometry& geometry,
                                                                  const Log* log) {
  RecordingDescription description;
  description.geometry = geometry;
  description.ring_name = config_.ring_name;
  description.producer = config_.producer;
  description.run_metadata = config_.run_metadata;
  description.producer_pid = producer_pid_;
  auto session = std::make_unique<Session>(config_, file, description, overwrite,
                                           geometry.group_payload_bytes(), log);
  session->start_ns = ioct::monotonic_ns();
  session->limit_s = seconds;
  session->end_ns = seconds > 0 ? session->start_ns + seconds_to_ns(seconds) : UINT64_MAX;
  session->next_status_ns = session->start_ns + seconds_to_ns(config_.status_interval_s);
  Session* raw = session.get();
  session->writer_thread = std::thread([raw] { raw->writer.run(); });
  auto view = std::make_shared<SessionView>();
  view->file = file;
  view->queue = session->queue;
  view->counters = session->counters;
  view->start_ns = session->start_ns;
  view->limit_s = seconds;
  std::lock_guard lock(mutex_);
  view_ = std::move(view);
  return session;
}

RecorderSummary RingRecorder::finish_session(std::unique_ptr<Session>& session, std::string reason,
                                             bool failed) {
  RecorderSummary summary;
  summary.file = session->file_path;
  summary.stop_reason = std::move(reason);
  summary.failed = failed;
  summary.seconds = static_cast<double>(ioct::monotonic_ns() - session->start_ns) / kNsPerS;
  session->queue->close();
  session->writer_thread.join();
  DiskWriter& writer = session->writer;
  if (writer.failed.load(std::memory_order_acquire)) {
    summary.failed = true;
    summary.stop_reason = "writing failed: " + writer.failure;
  }
  summary.counters = session->counters->snapshot();
  summary.counters[static_cast<std::size_t>(Counter::finished)] = 1;
  if (writer.busy_ns > 0) {
    summary.write_mb_per_s =
        static_cast<double>(summary.counters[static_cast<std::size_t>(Counter::bytes_written)]) /
        (static_cast<double>(writer.busy_ns) * 1e-9) * 1e-6;
  }
  try {
    session->file.close(summary.counters);
  } catch (const std::exception& e) {
    // A write that failed first keeps its reason: the close usually fails because of it.
    summary.stop_reason = (summary.failed ? summary.stop_reason + "; then " : std::string()) +
                          "closing the file failed: " + e.what();
    summary.failed = true;
  }
  session.reset();
  std::lock_guard lock(mutex_);
  view_.reset();
  last_ = summary;
  return summary;
}

std::string RingRecorder::submit(Command command) {
  const std::string verb = command.kind == CommandKind::start ? "record-start" : "record-stop";
  if (!running_.load(std::memory_order_acquire)) {
    return verb + ": the recorder is not running";
  }
  if (command.kind == CommandKind::start && !attached_.load(std::memory_order_acquire)) {
    return verb + ": the recorder is waiting for ring '" + config_.ring_name +
           "' (no producer): nothing to record yet";
  }
  std::lock_guard exchange(command_mutex_);
  std::unique_lock lock(mutex_);
  command_ = std::move(command);
  command_taken_ = false;
  command_answered_ = false;
  command_pending_.store(true, std::memory_order_release);
  // run()'s thread looks each poll interval, and each retry while it waits for the producer.
  const auto untaken_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  for (;;) {
    if (command_answered_) break;
    if (!command_taken_ && std::chrono::steady_clock::now() >= untaken_deadline) {
      command_pending_.store(false, std::memory_order_release);
      return verb + ": the recorder did not take the command up within 5 s; try again";
    }
    answered_cv_.wait_for(lock, std::chrono::milliseconds(50));
  }
  return answer_;
}

std::string RingRecorder::start_recording(const std::string& name, double seconds) {
  if (!std::isfinite(seconds) || seconds < 0 || seconds > 1e9) {
    return "record-start: seconds = " + format_value(seconds) +
           ": must be in [0, 1e9] (0: until record-stop)";
  }
  Command command;
  command.kind = CommandKind::start;
  command.seconds = seconds;
  try {
    command.file = recording_file(config_.standby ? config_.out : config_.out.parent_path(), name);
  } catch (const ConfigError& e) {
    return std::string("record-start: ") + e.what();
  }
  return submit(std::move(command));
}

std::string RingRecorder::stop_recording() {
  Command command;
  command.kind = CommandKind::stop;
  return submit(std::move(command));
}

void RingRecorder::serve_command(std::unique_ptr<Session>& session,
                                 const shm::RingGeometry& geometry, const Log* log,
                                 RecorderSummary& summary) {
  Command command;
  {
    std::lock_guard lock(mutex_);
    if (!command_pending_.load(std::memory_order_acquire)) return;
    command_pending_.store(false, std::memory_order_release);
    command_taken_ = true;
    command = command_;
  }
  std::string answer;
  if (command.kind == CommandKind::start) {
    std::error_code error;
    if (session) {
      answer = "record-start: already recording into " + session->file_path.string() +
               "; record-stop first";
    } else if (!config_.standby) {
      answer = "record-start: this recorder is not in standby (started with a file to record)";
    } else if (std::filesystem::symlink_status(command.file, error).type() !=
               std::filesystem::file_type::not_found) {
      answer = "record-start: " + command.file.string() +
               " exists; not overwriting it (choose another name)";
    } else {
      try {
        session = open_session(command.file, command.seconds, false, geometry, log);
        say(log, "recording ring '" + config_.ring_name + "' into " + command.file.string() +
                     (command.seconds > 0 ? " for " + format_value(command.seconds) + " s" : ""));
      } catch (const std::exception& e) {
        answer = "record-start: " + command.file.string() + ": " + e.what();
      }
    }
  } else if (!session) {
    answer = "record-stop: not recording";
  } else {
    summary = finish_session(session, "stopped by record-stop", false);
    say(log, "recording " + summary.file.string() + " finished: " + summary.stop_reason);
    // A recorder started with its file has nothing left to do: it ends, its summary the
    // recording's (in standby it waits for the next record-start).
    if (!config_.standby) stop_.store(true, std::memory_order_relaxed);
  }
  std::lock_guard lock(mutex_);
  answer_ = std::move(answer);
  command_answered_ = true;
  command_taken_ = false;  // answered: run()'s end has nothing of it left to answer
  answered_cv_.notify_all();
}

RecorderStatus RingRecorder::status() const {
  RecorderStatus out;
  out.attached = attached_.load(std::memory_order_acquire);
  out.standby = config_.standby;
  std::shared_ptr<const SessionView> view;
  {
    std::lock_guard lock(mutex_);
    view = view_;
    out.last = last_;
  }
  if (view) {
    out.recording = true;
    out.file = view->file;
    out.seconds = static_cast<double>(ioct::monotonic_ns() - view->start_ns) / kNsPerS;
    out.limit_seconds = view->limit_s;
    out.counters = view->counters->snapshot();
    out.queued = view->queue->queued();
    out.queue_capacity = view->queue->capacity();
  }
  return out;
}

RecorderSummary RingRecorder::run(const Log* log) {
  shm::AttachWait first_wait;
  first_wait.deadline_ns = ioct::monotonic_ns() + seconds_to_ns(config_.wait_s);
  first_wait.stop = &stop_;
  std::optional<shm::RingReader> reader = shm::attach_when_available(
      config_.ring_name, shm::ReaderOptions{config_.label}, first_wait, config_.wait_s);
  RecorderSummary summary;
  if (!reader) {
    summary.stop_reason = "stopped before the ring was readable";
    return summary;
  }
  shm::RingGeometry geometry = reader->geometry();
  producer_pid_ = reader->producer_pid();
  attached_.store(true, std::memory_order_release);

  std::unique_ptr<Session> session;
  if (!config_.standby) {
    session = open_session(config_.out, config_.run_s, config_.overwrite, geometry, log);
    say(log, "recording ring '" + config_.ring_name + "' into " + config_.out.string());
  } else {
    say(log, "standby on ring '" + config_.ring_name + "': recordings go into " +
                 config_.out.string() + " when started");
  }
  running_.store(true, std::memory_order_release);
  // Whatever ends run() ends an exchange in progress too.
  struct NotRunning {
    explicit NotRunning(RingRecorder& r) : recorder(r) {}
    NotRunning(const NotRunning&) = delete;
    NotRunning& operator=(const NotRunning&) = delete;
    NotRunning(NotRunning&&) = delete;
    NotRunning& operator=(NotRunning&&) = delete;
    ~NotRunning() {
      recorder.running_.store(false, std::memory_order_release);
      recorder.attached_.store(false, std::memory_order_release);
      std::lock_guard lock(recorder.mutex_);
      if (recorder.command_taken_ || recorder.command_pending_.load()) {
        recorder.command_pending_.store(false);
        recorder.answer_ = "the recorder stopped";
        recorder.command_answered_ = true;
        recorder.answered_cv_.notify_all();
      }
    }
    RingRecorder& recorder;
  } not_running(*this);

  // Reader counters of the attachments before this one (each attachment starts from zero); the
  // changes go to the recording under way, if any.
  shm::ReaderCounters earlier{};
  auto add_reader_counters = [&](const shm::ReaderCounters& now, shm::ReaderCounters& seen) {
    if (session) {
      SharedCounters& counters = *session->counters;
      counters.add(Counter::dropped_lapped, now.dropped_lapped - seen.dropped_lapped);
      counters.add(Counter::dropped_behind, now.dropped_behind - seen.dropped_behind);
      counters.add(Counter::producer_restarts, now.epoch_changes - seen.epoch_changes);
    }
    seen = now;
  };
  // Ends the recording under way; false when run() ends with it (not in standby).
  auto end_session = [&](const std::string& reason, bool failed) {
    summary = finish_session(session, reason, failed);
    if (config_.standby) {
      say(log, "recording " + summary.file.string() + " finished: " + summary.stop_reason);
    }
    return config_.standby;
  };

  const std::uint64_t status_ns = seconds_to_ns(config_.status_interval_s);
  const std::uint64_t poll_ns = seconds_to_ns(config_.poll_interval_s);
  summary.stop_reason = "stopped";
  for (;;) {
    if (command_pending_.load(std::memory_order_acquire)) {
      serve_command(session, geometry, log, summary);
    }
    const std::uint64_t now = ioct::monotonic_ns();
    if (stop_.load(std::memory_order_relaxed)) break;
    if (session) {
      if (now >= session->end_ns) {
        if (!end_session("time limit", false)) break;
        continue;
      }
      if (session->writer.failed.load(std::memory_order_acquire)) {
        if (!end_session("writing failed", true)) break;
        continue;
      }
      if (log != nullptr && status_ns > 0 && now >= session->next_status_ns) {
        print_status(*log, *session->counters,
                     static_cast<double>(now - session->start_ns) / kNsPerS,
                     session->bytes_at_last_status, config_.status_interval_s,
                     session->queue->queued(), session->queue->capacity());
        session->bytes_at_last_status = session->counters->get(Counter::bytes_written);
        session->next_status_ns = now + status_ns;
      }
    }
    shm::ReadTicket ticket;
    const shm::PollStatus poll = reader->begin_read(ticket);
    if (poll == shm::PollStatus::ready) {
      if (!session) {
        reader->end_read(ticket);  // standby: followed, not kept
      } else if (const std::optional<std::size_t> index = session->queue->try_take_free()) {
        GroupBuffer& buffer = session->queue->buffer(*index);
        shm::seqlock_copy(buffer.payload.data(), ticket.payload, ticket.payload_bytes);
        buffer.header = ticket.header;
        if (reader->end_read(ticket)) {
          session->queue->push_filled(*index);
        } else {
          session->queue->give_back_free(*index);
        }
      } else if (reader->end_read(ticket)) {
        session->counters->add(Counter::dropped_queue_full);  // intact, but no room to keep it
      }
      add_reader_counters(reader->counters(), earlier);
      continue;
    }
    add_reader_counters(reader->counters(), earlier);
    if (poll == shm::PollStatus::lapped) continue;  // counted by the reader; the ring goes on
    if (poll == shm::PollStatus::empty) {
      reader->heartbeat();
      std::this_thread::sleep_for(std::chrono::nanoseconds(poll_ns));
      continue;
    }
    // producer_gone: every group it published has been read.
    if (config_.exit_when_producer_gone) {
      if (session) end_session("producer gone", false);
      summary.stop_reason = "producer gone";
      break;
    }
    reader.reset();
    attached_.store(false, std::memory_order_release);
    earlier = {};
    say(log, "producer gone (ring '" + config_.ring_name + "' closed or replaced): waiting for it");
    shm::AttachWait again;
    again.unbounded = true;
    again.stop = &stop_;
    // Reported each retry, so that commands (record-stop, record-status) are served meanwhile.
    again.report_interval_ns = again.retry_interval_ns;
    std::uint64_t next_waiting_line = ioct::monotonic_ns() + status_ns;
    again.on_waiting = [&](shm::RingErrc last, std::uint64_t waited_ns) {
      if (command_pending_.load(std::memory_order_acquire)) {
        serve_command(session, geometry, log, summary);
      }
      if (status_ns == 0 || ioct::monotonic_ns() < next_waiting_line) return;
      next_waiting_line = ioct::monotonic_ns() + status_ns;
      char line[128];
      std::snprintf(line, sizeof line, "waiting for the producer for %.0f s: %s",
                    static_cast<double>(waited_ns) / kNsPerS,
                    std::string(shm::to_string(last)).c_str());
      say(log, line);
    };
    reader =
        shm::attach_when_available(config_.ring_name, shm::ReaderOptions{config_.label}, again);
    if (!reader) break;  // stopped while waiting
    producer_pid_ = reader->producer_pid();
    if (!(reader->geometry() == geometry)) {
      const shm::RingGeometry& g = reader->geometry();
      const std::string reason =
          "the producer came back with another geometry (" + std::to_string(g.samples_per_ascan) +
          " samples x " + std::to_string(g.ascans_per_bscan) + " A-scans x " +
          std::to_string(g.bscans_per_group) + " B-scans; the recording has " +
          std::to_string(geometry.samples_per_ascan) + " x " +
          std::to_string(geometry.ascans_per_bscan) + " x " +
          std::to_string(geometry.bscans_per_group) + "): start a new recording";
      geometry = g;
      if (session) {
        if (!end_session(reason, true)) break;
      }
      attached_.store(true, std::memory_order_release);
      say(log, "producer back with another geometry: standby");
      continue;
    }
    attached_.store(true, std::memory_order_release);
    if (session) {
      session->counters->add(Counter::producer_restarts);
      say(log, "producer back: recording goes on");
    } else {
      say(log, "producer back");
    }
  }
  if (session) {
    const bool stopped = stop_.load(std::memory_order_relaxed);
    summary = finish_session(session, stopped ? "stopped" : summary.stop_reason, summary.failed);
  }
  if (config_.standby) {
    // The figures are the last recording's; its end was reported when it came (and in
    // record-status), so the recorder's own exit does not fail for it.
    const std::string how = stop_.load() ? "stopped" : summary.stop_reason;
    summary.stop_reason =
        how + (summary.file.empty() ? " in standby, nothing recorded"
                                    : " in standby; the last recording: " + summary.stop_reason);
    summary.failed = false;
  }
  return summary;
}

}  // namespace ioct::ringrec
