// ioct-record's work: attach to the ring like ioct-gpu (read-only, its own reader status), copy
// every group into a bounded queue, and write the queue into an HDF5 ring recording on a thread
// of its own. A disk that cannot keep up fills the queue and groups are dropped and counted, the
// ring is never waited for (and ioct-rt cannot be: readers cannot affect the writer). Waits for
// the producer to come back when it goes, and appends its groups to the same file.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include "ioct/ringrec/ring_recording_format.hpp"

namespace ioct::ringrec {

struct RecorderConfig {
  std::string ring_name = "ioct-ring";
  std::filesystem::path out;
  bool overwrite = false;
  double run_s = 0.0;                    // stop after this long attached; 0: until request_stop()
  double wait_s = 10.0;                  // first attachment: give up after this long
  bool exit_when_producer_gone = false;  // finish instead of waiting for the producer's return
  std::uint32_t queue_groups = 8;        // groups that may wait for the disk
  std::uint64_t max_bytes = 0;           // stop writing (count drops) past this; 0: no cap
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
};

class RingRecorder {
 public:
  explicit RingRecorder(RecorderConfig config);
  // Runs until the time limit, request_stop(), the producer's end (exit_when_producer_gone) or
  // a writer failure, then closes the file in order. Status lines go to `status` when given.
  // Throws shm::RingError when the ring never became readable, and what creating the file throws.
  RecorderSummary run(std::ostream* status = nullptr);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }

 private:
  RecorderConfig config_;
  std::atomic<bool> stop_{false};
};

}  // namespace ioct::ringrec
