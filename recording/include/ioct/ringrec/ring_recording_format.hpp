// The HDF5 ring recording ("ioct-ring-recording", version 1): what ioct-record writes and
// RingRecordingReader reads. docs/recording-format.md describes it for other readers (h5py).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace ioct::ringrec {

inline constexpr std::string_view kFormatName = "ioct-ring-recording";
inline constexpr std::uint32_t kFormatVersion = 1;

// Datasets.
inline constexpr const char* kGroupsDataset = "groups";              // [n][bscan][ascan][sample]
inline constexpr const char* kSlotHeadersDataset = "slot_headers";   // [n][sizeof(SlotHeader)] u8
inline constexpr const char* kChecksumsDataset = "group_checksums";  // [n] u64
inline constexpr const char* kCountersDataset = "counters";          // [kCounterCount] u64

// What the recorder counts, in the file's `counters` dataset in this order (its attribute
// `names` lists them), and in its status line.
enum class Counter : std::size_t {
  groups_written,      // groups in the file
  bytes_written,       // payload + slot header bytes of those groups
  dropped_lapped,      // the producer overwrote the slot before or while it was copied
  dropped_behind,      // skipped when the recorder fell a whole ring behind
  dropped_queue_full,  // read intact but the write queue was full (the disk too slow)
  dropped_disk_full,   // not written: no room on the file system or past --max-bytes
  producer_restarts,   // new producer epochs followed (ioct-rt restarted)
  finished,            // 1 once the recorder closed the file in order
  count_
};
inline constexpr std::size_t kCounterCount = static_cast<std::size_t>(Counter::count_);
inline constexpr std::array<std::string_view, kCounterCount> kCounterNames = {
    "groups_written",     "bytes_written",     "dropped_lapped",    "dropped_behind",
    "dropped_queue_full", "dropped_disk_full", "producer_restarts", "finished"};

using CounterValues = std::array<std::uint64_t, kCounterCount>;

// The checksum kept per group: 64-bit FNV-1a over the payload's little-endian 64-bit words (a
// tail of fewer than 8 bytes is zero-padded). Fast enough for 260 MB/s on one core; it tells a
// corrupted chunk apart from an intact one, it is no defence against tampering.
std::uint64_t group_checksum(std::span<const std::byte> payload) noexcept;

}  // namespace ioct::ringrec
