// A ring made for a benchmark: a writer on a name unique to this process, optionally with every
// slot's payload filled with the slot pattern, and readers attached to it. The names are also
// unlinked if the run is interrupted (SIGINT, SIGTERM), so a stopped benchmark leaves no
// shared-memory object behind.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"

namespace ioct::bench {

enum class SlotFill { none, pattern };

class BenchRing {
 public:
  // Creates the ring "ioct-bench-<pid>-<tag>". With SlotFill::pattern every slot is claimed once,
  // filled with slot_pattern_word(slot, i) and published, so groups 0..slots-1 are out.
  BenchRing(const std::string& tag, const shm::RingGeometry& geometry, std::uint64_t slot_count,
            SlotFill fill);

  // Attaches a read-only reader. Its heartbeat object is registered for cleanup too.
  shm::RingReader attach_reader(const std::string& label, bool publish_status = true) const;

  // Claims and publishes `groups` groups without touching their payload (the slots keep their
  // pattern). Not timed by callers: it only advances the cursor.
  void publish(std::uint64_t groups) noexcept;

  shm::RingWriter& writer() noexcept { return writer_; }
  const shm::RingWriter& writer() const noexcept { return writer_; }
  const shm::RingLayout& layout() const noexcept { return writer_.layout(); }
  const std::string& name() const noexcept { return writer_.config().name; }

 private:
  shm::RingWriter writer_;
};

// Payload of `slot` inside a reader's mapping, for copies that bypass the protocol (anchors).
std::span<const std::byte> slot_payload(const shm::RingReader& reader, std::uint64_t slot);

// True when `payload` holds slot `slot`'s pattern at its first, middle and last word.
bool spot_check_pattern(std::span<const std::byte> payload, std::uint64_t slot);

// Bytes free on the file system that holds POSIX shared memory (/dev/shm); 0 when unknown.
std::uint64_t shm_free_bytes();

}  // namespace ioct::bench
