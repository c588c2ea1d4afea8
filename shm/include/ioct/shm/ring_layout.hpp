// The byte layout of the ring object: the contract between ioct-rt and every reader.
//
//   offset 0                 RingHeader (one page)
//   first_slot_offset        slot 0: SlotControl + SlotHeader (one page), payload (page aligned)
//   + slot_stride            slot 1 ...
//
// Everything here is trivially copyable and holds no pointers. Words that change while the
// ring is live are plain uint64_t accessed through atomic_word.hpp; everything else is written
// once before the header's magic is published, or under a slot's seqlock.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "ioct/shm/ring_geometry.hpp"

namespace ioct::shm {

inline constexpr std::uint64_t kRingMagic = 0x474E4952'54434F49;  // "IOCTRING" in memory order
inline constexpr std::uint32_t kRingLayoutVersion = 1;
inline constexpr std::uint64_t kPageBytes = 4096;
inline constexpr std::size_t kCacheLineBytes = 64;

// Lifecycle of a ring object, kept in RingHeader::state.
enum class RingState : std::uint64_t {
  initializing = 0,  // being (re)initialised by a producer: readers wait
  live = 1,          // a producer publishes into it
  closed = 2,        // the producer exited in order and unlinked the name: readers reattach
  retired = 3,       // a new producer replaced this object by another one: readers reattach
};

struct RingHeader {
  std::uint64_t magic;  // kRingMagic, stored last (release) when the object is ready
  std::uint32_t layout_version;
  std::uint32_t header_bytes;       // sizeof(RingHeader) of the writer
  std::uint32_t slot_header_bytes;  // sizeof(SlotHeader) of the writer
  std::uint32_t reserved0;
  RingGeometry geometry;
  std::uint32_t reserved1;
  std::uint64_t slot_count;
  std::uint64_t slot_stride;            // bytes between slot starts, a page multiple
  std::uint64_t slot_payload_offset;    // payload start within a slot, a page multiple
  std::uint64_t slot_payload_capacity;  // bytes available for payload in each slot
  std::uint64_t group_payload_bytes;    // bytes of one group, <= capacity
  std::uint64_t first_slot_offset;      // slot 0 start within the object
  std::uint64_t total_bytes;            // size the object must have
  std::uint64_t producer_pid;
  std::uint64_t producer_start_ticks;  // the producer's start time, tells a reused pid apart
  std::uint64_t created_realtime_ns;

  // Live words (atomic access only), each on its own cache line.
  alignas(kCacheLineBytes) std::uint64_t producer_epoch;  // new value at every producer start
  std::uint64_t state;                                    // RingState
  alignas(kCacheLineBytes) std::uint64_t published;       // groups published in this epoch
};

// The seqlock word of a slot, alone on its cache line.
//   2g+1: group g is being written; 2g+2: group g is published; 0: never written this epoch.
struct SlotControl {
  alignas(kCacheLineBytes) std::uint64_t sequence;
};

inline constexpr std::uint64_t writing_sequence(std::uint64_t group) {
  return 2 * group + 1;
}
inline constexpr std::uint64_t published_sequence(std::uint64_t group) {
  return 2 * group + 2;
}

// BscanMarker::flags
inline constexpr std::uint32_t kBscanReversed = 1u << 0;     // acquired right to left
inline constexpr std::uint32_t kBscanVolumeStart = 1u << 1;  // first B-scan of a volume
inline constexpr std::uint32_t kBscanVolumeEnd = 1u << 2;    // last B-scan of a volume

// Where one B-scan of the group belongs, so the reader rebuilds volumes without guessing.
struct BscanMarker {
  std::uint64_t volume_index;
  std::uint32_t bscan_in_volume;
  std::uint32_t flags;
  float galvo_start[2];  // commanded x, y at the first active A-scan (scan units)
  float galvo_end[2];    // commanded x, y at the last active A-scan
};

// SlotHeader::status_flags
inline constexpr std::uint32_t kStatusMissedTriggers = 1u << 0;
inline constexpr std::uint32_t kStatusClockFault = 1u << 1;
inline constexpr std::uint32_t kStatusOverrun = 1u << 2;
inline constexpr std::uint32_t kStatusLaserOn = 1u << 3;
inline constexpr std::uint32_t kStatusGalvoFault = 1u << 4;
inline constexpr std::uint32_t kStatusSimulated = 1u << 5;
inline constexpr std::uint32_t kStatusReplay =
    1u << 6;  // played back from a recording (ioct-rt --replay)

// Metadata of one group. Written by the producer between the odd and the even sequence, copied
// by readers under the seqlock. The writer fills group_index, producer_epoch, payload_bytes and
// t_publish_ns itself at publish; the rest is the producer's.
struct SlotHeader {
  std::uint64_t group_index;
  std::uint64_t producer_epoch;
  std::uint64_t payload_bytes;
  std::uint64_t first_sweep_counter;  // hardware sweep counter of the group's first record
  std::uint64_t t_first_sweep_ns;     // CLOCK_MONOTONIC
  std::uint64_t t_last_sweep_ns;
  std::uint64_t t_publish_ns;
  std::uint32_t bscan_count;
  std::uint32_t active_ascan_begin;  // active A-scans [begin, end) of each B-scan's records
  std::uint32_t active_ascan_end;
  std::uint32_t scan_pattern_id;
  std::uint32_t scan_generation;
  std::uint32_t status_flags;
  std::uint32_t missed_sweeps;
  std::uint32_t reserved0;
  std::array<BscanMarker, kMaxBscansPerGroup> bscans;
};

static_assert(std::is_trivially_copyable_v<RingHeader> && std::is_standard_layout_v<RingHeader>);
static_assert(std::is_trivially_copyable_v<SlotHeader> && std::is_standard_layout_v<SlotHeader>);
static_assert(std::is_trivially_copyable_v<SlotControl>);
static_assert(sizeof(RingHeader) <= kPageBytes);
static_assert(sizeof(SlotControl) + sizeof(SlotHeader) <= kPageBytes);

// Offsets and sizes derived from a geometry; the one place that arithmetic lives.
struct RingLayout {
  std::uint64_t slot_count = 0;
  std::uint64_t group_payload_bytes = 0;
  std::uint64_t slot_payload_capacity = 0;
  std::uint64_t slot_payload_offset = 0;
  std::uint64_t slot_stride = 0;
  std::uint64_t first_slot_offset = 0;
  std::uint64_t total_bytes = 0;

  // payload_capacity 0 means "exactly one group, rounded up to a page". Throws
  // RingError(bad_config) naming the value for zero or too few slots, a payload larger than the
  // slot, or sizes that overflow.
  static RingLayout compute(const RingGeometry& geometry, std::uint64_t slot_count,
                            std::uint64_t payload_capacity = 0);
};

// Checks a header read from an object of object_bytes bytes. Throws RingError (not_ready,
// producer_gone, too_small, foreign, wrong_version, corrupt) with a message naming the object and
// the offending field. Returns the layout the header describes.
RingLayout validate_header(const RingHeader& header, std::uint64_t object_bytes,
                           const char* object_name);

}  // namespace ioct::shm
