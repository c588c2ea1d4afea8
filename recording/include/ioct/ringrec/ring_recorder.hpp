// ioct-record's work: attach to the ring like ioct-gpu (read-only, its own reader status), copy
// every group into a bounded queue, and write the queue into an HDF5 ring recording on a thread
// of its own. A disk that cannot keep up fills the queue and groups are dropped and counted, the
// ring is never waited for (and ioct-rt cannot be: readers cannot affect the writer). Waits for
// the producer to come back when it goes, and appends its groups to the same file.
//
// In standby the recorder follows the ring (its reader status held, nothing copied or written)
// and records only between start_recording() and stop_recording() (or the recording's time
// limit), each recording into a new file of the `out` directory, for as long as it runs.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "ioct/common/log.hpp"
#include "ioct/ringrec/ring_recording_format.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::ringrec {

struct RecorderConfig {
  std::string ring_name = "ioct-ring";
  std::filesystem::path out;  // the file; in standby the directory the recordings go into
  bool standby = false;       // record only when asked (start_recording())
  bool overwrite = false;
  double run_s = 0.0;    // stop after this long recording; 0: until request_stop() (not in standby)
  double wait_s = 10.0;  // first attachment: give up after this long
  bool exit_when_producer_gone = false;       // finish instead of waiting for the producer's return
  std::uint32_t queue_groups = 8;             // groups that may wait for the disk
  std::uint64_t max_bytes = 0;                // stop writing (count drops) past this; 0: no cap
  std::uint64_t reserve_bytes = 64ull << 20;  // leave this much free on the file system
  double status_interval_s = 1.0;             // 0: no status lines
  double poll_interval_s = 0.001;
  std::string label = "ioct-record";
  std::string producer = "ioct-record";
  std::string run_metadata;

  // Throws ConfigError naming the key and value.
  void validate() const;
};

struct RecorderSummary {
  CounterValues counters{};
  std::string stop_reason;  // "time limit", "stopped", "producer gone", or the error
  bool failed = false;      // the writer failed (a message says why); the file keeps what it had
  double seconds = 0.0;
  double write_mb_per_s = 0.0;  // payload bytes over the time the writer spent writing
  std::filesystem::path file;   // the recording these figures are of; empty: none was made
};

// What record-status shows: the recording under way, if any, and the last one finished.
struct RecorderStatus {
  bool attached = false;  // reading the ring (false: waiting for its producer)
  bool recording = false;
  bool standby = false;
  std::filesystem::path file;
  double seconds = 0.0;        // since the recording started
  double limit_seconds = 0.0;  // its time limit; 0: none
  CounterValues counters{};    // of the recording under way
  std::size_t queued = 0;
  std::size_t queue_capacity = 0;
  std::optional<RecorderSummary> last;  // the last recording finished
};

// Longest recording name start_recording() takes (the file name, ".h5" included).
inline constexpr std::size_t kMaxRecordingNameBytes = 128;

// The file a recording name gives in `directory`: the name, with ".h5" added when it lacks it.
// Throws ConfigError (key "name") for an empty or over-long name, a path separator, a control
// byte or a name of only dots.
std::filesystem::path recording_file(const std::filesystem::path& directory,
                                     const std::string& name);

class RingRecorder {
 public:
  explicit RingRecorder(RecorderConfig config);
  // Runs until the time limit, request_stop(), the producer's end (exit_when_producer_gone) or
  // a writer failure, then closes the file in order. Status lines go to `log` when given.
  // Throws shm::RingError when the ring never became readable, and what creating the file throws.
  RecorderSummary run(const Log* log = nullptr);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }

  // From any thread while run() runs. Each returns "" when done, else why not (a message that
  // names the command and the value). start_recording() waits until the file is created (or
  // refused); stop_recording() until the file is closed in order.
  std::string start_recording(const std::string& name, double seconds);
  std::string stop_recording();
  RecorderStatus status() const;

 private:
  struct Session;
  struct SessionView;
  enum class CommandKind { none, start, stop };
  struct Command {
    CommandKind kind = CommandKind::none;
    std::filesystem::path file;
    double seconds = 0.0;
  };
  // Hands a command to run()'s thread and waits for its answer.
  std::string submit(Command command);
  // run()'s side: does the pending command, if any, and answers it. A record-stop puts the
  // recording's summary in `summary`; without standby it also ends run() (stop_ is set).
  void serve_command(std::unique_ptr<Session>& session, const shm::RingGeometry& geometry,
                     const Log* log, RecorderSummary& summary);
  std::unique_ptr<Session> open_session(const std::filesystem::path& file, double seconds,
                                        bool overwrite, const shm::RingGeometry& geometry,
                                        const Log* log);
  RecorderSummary finish_session(std::unique_ptr<Session>& session, std::string reason,
                                 bool failed);

  RecorderConfig config_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> attached_{false};
  std::atomic<bool> running_{false};
  std::uint64_t producer_pid_ = 0;  // the attached ring's producer (run()'s thread only)

  // Commands: one at a time, from the control side to run()'s thread.
  std::mutex command_mutex_;  // held by one submitter at a time, for the whole exchange
  mutable std::mutex mutex_;  // guards what follows
  std::condition_variable answered_cv_;
  std::atomic<bool> command_pending_{false};
  Command command_;
  bool command_taken_ = false;
  bool command_answered_ = false;
  std::string answer_;
  // What status() reads: shared with the session under way, and the last summary.
  std::shared_ptr<const SessionView> view_;
  std::optional<RecorderSummary> last_;
};

}  // namespace ioct::ringrec
