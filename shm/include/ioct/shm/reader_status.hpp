// Each reader's heartbeat and counters, in a small shm object of its own that the producer reads.
//
// The ring itself is mapped read-only by readers, so what a reader reports travels the other way
// through an object it owns: "<ring>.reader.<pid>.<n>". The producer's housekeeping thread lists
// them; a status whose process is gone is reaped.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ioct/shm/shm_object.hpp"

namespace ioct::shm {

inline constexpr std::uint64_t kReaderStatusMagic = 0x44414552'54434F49;  // "IOCTREAD"
inline constexpr std::uint32_t kReaderStatusVersion = 1;
inline constexpr std::size_t kReaderLabelBytes = 32;
// The most directory entries one scan looks at (the scan runs on ioct-rt's housekeeping thread).
inline constexpr std::size_t kMaxDirectoryEntries = 4096;

// How a reader's groups ended up. Per epoch: published == consumed + dropped_lapped +
// dropped_behind once the reader has caught up.
struct ReaderCounters {
  std::uint64_t consumed = 0;        // copied intact
  std::uint64_t dropped_lapped = 0;  // the writer overwrote the slot during or before the copy
  std::uint64_t dropped_behind = 0;  // skipped when the reader fell a whole ring behind
  std::uint64_t resyncs = 0;         // times it jumped to the newest group
  std::uint64_t epoch_changes = 0;   // producer restarts it followed
  std::uint64_t dropped() const { return dropped_lapped + dropped_behind; }
};

struct ReaderStatusBlock {
  std::uint64_t magic;
  std::uint32_t layout_version;
  std::uint32_t reserved0;
  std::uint64_t pid;
  std::uint64_t start_ticks;
  char label[kReaderLabelBytes];
  // Live words (atomic access only).
  std::uint64_t heartbeat_ns;  // CLOCK_MONOTONIC of the reader's last poll
  std::uint64_t epoch;
  std::uint64_t position;  // next group it will read
  std::uint64_t consumed;
  std::uint64_t dropped_lapped;
  std::uint64_t dropped_behind;
  std::uint64_t resyncs;
  std::uint64_t epoch_changes;
};

// The reader's side: creates and updates its status object; removes it on destruction.
class ReaderStatusPublisher {
 public:
  // The object gets `mode` and the ring's own group, so whoever may read the ring (and the
  // producer, which owns it) may read the status, and nobody else.
  ReaderStatusPublisher(const std::string& ring_name, const std::string& label, unsigned mode,
                        unsigned group_id);
  ReaderStatusPublisher(ReaderStatusPublisher&&) noexcept = default;
  ReaderStatusPublisher& operator=(ReaderStatusPublisher&& other) noexcept;
  ~ReaderStatusPublisher();

  void update(std::uint64_t now_ns, std::uint64_t epoch, std::uint64_t position,
              const ReaderCounters& counters) noexcept;
  const std::string& object_name() const noexcept { return object_.name(); }

 private:
  ShmObject object_;
};

// The producer's view of one reader.
struct ReaderReport {
  std::string object_name;
  std::string label;
  std::uint64_t pid = 0;
  bool alive = false;
  std::uint64_t heartbeat_age_ns = 0;
  std::uint64_t epoch = 0;
  std::uint64_t position = 0;
  ReaderCounters counters;
};

// Lists the status objects of `ring_name`'s readers (beside the ring, in its directory). Objects
// that are not valid status blocks -- a FIFO, a link, another kind of file, a short or foreign
// block -- are skipped (and named in `skipped` when given). Never blocks: objects are opened
// non-blocking and read, not mapped; at most kMaxDirectoryEntries entries are looked at.
std::vector<ReaderReport> scan_reader_status(const std::string& ring_name,
                                             std::vector<std::string>* skipped = nullptr);

}  // namespace ioct::shm
