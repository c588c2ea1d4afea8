// Which scan pattern holds for which sweep, on the acquisition thread alone.
//
// The DAC is fed ahead of the digitizer, so a new pattern is scheduled when the feed reaches a
// volume boundary (that also starts a group), and the groups the digitizer records later are
// described with the pattern that was being scanned then. An entry says: from sweep
// `first_sweep` on (counted since arming), `pattern` is scanned, its first volume has index
// `first_volume`, and its groups carry `generation`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/scan/scan_pattern.hpp"

namespace ioct::rt {

struct ScheduledScan {
  std::uint64_t first_sweep = 0;
  std::uint64_t first_volume = 0;
  std::uint32_t generation = 0;
  const scan::ScanPattern* pattern = nullptr;
};

class ScanSchedule {
 public:
  static constexpr std::size_t kMaxEntries = 8;

  // Starts over at sweep 0 with `pattern`; the feed cursor is placed at trajectory sweep
  // `first_feed_sweep` (the galvo lead).
  void reset(const scan::ScanPattern* pattern, std::uint32_t generation, std::uint64_t first_volume,
             std::uint64_t sweeps_per_group, std::uint64_t first_feed_sweep) noexcept;

  // The position for the next trajectory sweep of the feed, then advances. When the sweep
  // starts a volume and a group, `offer()` is asked for a new pattern (nullptr: none) first.
  template <typename Offer>
  hal::GalvoSample next_position(Offer offer) noexcept {
    if (countdown_to_boundary_ == 0) {
      countdown_to_boundary_ = boundary_period_;
      if (count_ < kMaxEntries) {
        if (const scan::ScanPattern* next = offer()) schedule(next);
      }
    }
    --countdown_to_boundary_;
    const ScheduledScan& now = entries_[count_ - 1];
    const std::uint64_t index = feed_sweep_ - now.first_sweep;
    ++feed_sweep_;
    return now.pattern->at(index);
  }

  // The entry that holds for a group starting at `sweep` (the latest entry at or before it).
  const ScheduledScan& at(std::uint64_t sweep) const noexcept;
  // Drops the entries that end at or before `sweep` (the digitizer is past them). Returns in
  // `retired` (up to kMaxEntries) the patterns no remaining entry uses; returns their count.
  std::size_t retire_before(std::uint64_t sweep,
                            std::array<const scan::ScanPattern*, kMaxEntries>& retired) noexcept;

  const ScheduledScan& newest() const noexcept { return entries_[count_ - 1]; }
  std::size_t entries() const noexcept { return count_; }
  std::uint64_t feed_sweep() const noexcept { return feed_sweep_; }
  // Volume index the next volume of the newest entry would have at `sweep`.
  std::uint64_t volume_at(std::uint64_t sweep) const noexcept;

 private:
  void schedule(const scan::ScanPattern* pattern) noexcept;

  std::array<ScheduledScan, kMaxEntries> entries_{};
  std::size_t count_ = 0;
  std::uint64_t feed_sweep_ = 0;
  // Switches happen where a volume boundary and a group boundary meet: every lcm of the two.
  std::uint64_t boundary_period_ = 1;
  std::uint64_t countdown_to_boundary_ = 0;
};

}  // namespace ioct::rt
