// The single producer of a ring. Publishing never waits, allocates, locks or enters the kernel.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ioct/shm/reader_status.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/shm_object.hpp"

namespace ioct::shm {

enum class MemoryLock { required, best_effort, none };

struct RingConfig {
  std::string name = "ioct-ring";  // POSIX shm name, no slash
  RingGeometry geometry;
  std::uint64_t slot_count = 8;
  std::uint64_t slot_payload_capacity = 0;  // 0: one group, rounded up to a page
  std::string group;                        // group owning the object; empty: the creator's
  unsigned mode = 0640;
  MemoryLock memory_lock = MemoryLock::best_effort;

  // Throws RingError(bad_config) naming the key and the value.
  void validate() const;
};

// What create() found under the name and what it did about it (the stale-object policy).
enum class StartupAction {
  created,         // no object existed
  reused_stale,    // a dead producer's object of the same layout: reinitialised in place,
                   // attached readers see the new epoch and resync
  replaced_stale,  // a dead producer's object of another layout: retired and unlinked
};

class RingWriter {
 public:
  // Creates the ring, applying the stale-object policy; refuses a name owned by a live producer
  // (RingError owned_by_live_producer) or by something that is not a ring (RingError foreign).
  static RingWriter create(const RingConfig& config);

  RingWriter(RingWriter&& other) noexcept;
  RingWriter& operator=(RingWriter&&) = delete;
  ~RingWriter();

  // A slot handed to the producer: fill `payload` and `header` (zero copy), then publish().
  struct Claim {
    std::uint64_t group = 0;
    SlotHeader* header = nullptr;
    std::span<std::byte> payload;
  };

  // Marks the next slot in progress (odd sequence) and returns it. Wait-free.
  Claim claim() noexcept;
  // Stamps group index, epoch, payload size and publish time, publishes (even sequence, release)
  // and advances the cursor. Wait-free; clock_gettime(CLOCK_MONOTONIC) is served by the vDSO.
  void publish(const Claim& claim) noexcept;

  // Orderly shutdown: marks the ring closed so readers reattach, then unlinks the name.
  void close() noexcept;

  // Housekeeping (never on the hot path): the status objects of this ring's readers.
  std::vector<ReaderReport> readers() const;
  // Removes status objects whose reader process is gone; returns how many.
  std::size_t reap_dead_readers() const;

  const RingLayout& layout() const noexcept { return layout_; }
  const RingConfig& config() const noexcept { return config_; }
  std::uint64_t epoch() const noexcept { return epoch_; }
  std::uint64_t published() const noexcept { return next_group_; }
  StartupAction startup_action() const noexcept { return startup_action_; }
  bool memory_locked() const noexcept { return memory_locked_; }

 private:
  RingWriter(RingConfig config, RingLayout layout, ShmObject object, StartupAction action);
  void initialize(bool in_place);
  RingHeader& header() const noexcept;
  std::byte* slot(std::uint64_t index) const noexcept;

  RingConfig config_;
  RingLayout layout_;
  ShmObject object_;
  StartupAction startup_action_;
  bool memory_locked_ = false;
  bool open_ = true;
  std::uint64_t epoch_ = 0;
  std::uint64_t next_group_ = 0;  // the writer's own copy of the cursor
};

}  // namespace ioct::shm
