// One reader of a ring. It maps the ring read-only and never makes the writer wait: it follows
// the cursor, copies a slot, then re-checks the slot's sequence; a changed sequence means the
// writer lapped it, and the copy is discarded and counted as a drop.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "ioct/shm/reader_status.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/shm_object.hpp"

namespace ioct::shm {

struct ReaderOptions {
  std::string label = "reader";  // shown to the producer
  bool publish_status = true;    // create a heartbeat/counter object for the producer
  unsigned status_mode = 0640;   // with the ring's group: readable by the producer
};

enum class PollStatus {
  ready,          // a group was read (or a ticket issued)
  empty,          // nothing new yet
  lapped,         // the copy was overwritten while it was made: discarded and counted
  producer_gone,  // the producer closed or replaced the ring and every group it published has
                  // been read (or the state is garbage): attach again, which finds the new
                  // producer or says what is wrong
};

// A slot handed out by begin_read(). Copy `payload` (memcpy, DMA, cudaMemcpyAsync), then ask
// end_read() whether what was copied is intact.
struct ReadTicket {
  std::uint64_t group = 0;
  std::uint64_t epoch = 0;
  SlotHeader header{};  // already checked: copied under the seqlock
  const std::byte* payload = nullptr;
  std::uint64_t payload_bytes = 0;
  std::uint64_t slot_index = 0;
};

class RingReader {
 public:
  // Maps the ring read-only and validates its header. Throws RingError: not_found, permission,
  // not_ready, producer_gone, too_small, foreign, wrong_version, corrupt.
  static RingReader attach(const std::string& name, const ReaderOptions& options = {});

  RingReader(RingReader&&) noexcept = default;
  RingReader& operator=(RingReader&&) noexcept = default;
  ~RingReader() = default;

  // Issues a ticket for the next group, resyncing first when the producer restarted or the reader
  // fell a whole ring behind. Returns ready, empty or producer_gone.
  PollStatus begin_read(ReadTicket& ticket) noexcept;
  // True when the slot still holds the ticket's group, i.e. everything copied since begin_read()
  // is intact; false counts a drop. Either way the reader moves past the ticket's group.
  bool end_read(const ReadTicket& ticket) noexcept;

  // begin_read + memcpy into `payload` + end_read. Throws std::invalid_argument when `payload`
  // is smaller than a group. On ready, `header` and `payload` hold an intact group.
  PollStatus read_next(std::span<std::byte> payload, SlotHeader& header);

  // Refreshes the heartbeat while the reader is idle (polling refreshes it too).
  void heartbeat() noexcept;

  const RingGeometry& geometry() const noexcept { return geometry_; }
  const RingLayout& layout() const noexcept { return layout_; }
  const ReaderCounters& counters() const noexcept { return counters_; }
  std::uint64_t position() const noexcept { return next_group_; }
  std::uint64_t epoch() const noexcept { return epoch_; }
  // The producer's process id as the ring's header names it (set before the ring is published).
  std::uint64_t producer_pid() const noexcept;
  const std::string& name() const noexcept { return object_.name(); }
  // The whole read-only mapping, e.g. for cudaHostRegister.
  const std::byte* mapping() const noexcept { return object_.data(); }
  std::uint64_t mapping_bytes() const noexcept { return object_.size(); }
  std::optional<std::string> status_object_name() const;

 private:
  RingReader(ShmObject object, RingLayout layout, std::optional<ReaderStatusPublisher> status);
  const RingHeader& header() const noexcept;
  const std::byte* slot(std::uint64_t index) const noexcept;
  void resync_to(std::uint64_t group) noexcept;
  void report() noexcept;

  ShmObject object_;
  RingLayout layout_;
  RingGeometry geometry_;
  std::optional<ReaderStatusPublisher> status_;
  std::uint64_t epoch_ = 0;
  std::uint64_t next_group_ = 0;
  ReaderCounters counters_;
};

// Copies bytes that a seqlock writer may be overwriting at the same moment. The caller validates
// the copy afterwards by the sequence; the ThreadSanitizer build is told not to report the race.
void seqlock_copy(void* dst, const void* src, std::size_t bytes) noexcept;

}  // namespace ioct::shm
