#include "scan_schedule.hpp"

#include <numeric>

namespace ioct::rt {

void ScanSchedule::reset(const scan::ScanPattern* pattern, std::uint32_t generation,
                         std::uint64_t first_volume, std::uint64_t sweeps_per_group,
                         std::uint64_t first_feed_sweep) noexcept {
  entries_[0] = {0, first_volume, generation, pattern};
  count_ = 1;
  boundary_period_ = std::lcm(pattern->timing.sweeps_per_volume(), sweeps_per_group);
  feed_sweep_ = first_feed_sweep;
  // Samples until the first boundary after sweep 0 (where the entry itself starts).
  const std::uint64_t into = first_feed_sweep % boundary_period_;
  if (first_feed_sweep == 0) {
    countdown_to_boundary_ = boundary_period_;
  } else {
    countdown_to_boundary_ = into == 0 ? 0 : boundary_period_ - into;
  }
}

void ScanSchedule::schedule(const scan::ScanPattern* pattern) noexcept {
  const ScheduledScan& last = entries_[count_ - 1];
  const std::uint64_t volumes =
      (feed_sweep_ - last.first_sweep) / last.pattern->timing.sweeps_per_volume();
  entries_[count_] = {feed_sweep_, last.first_volume + volumes, last.generation + 1, pattern};
  ++count_;
}

const ScheduledScan& ScanSchedule::at(std::uint64_t sweep) const noexcept {
  std::size_t i = count_ - 1;
  while (i > 0 && entries_[i].first_sweep > sweep) --i;
  return entries_[i];
}

std::uint64_t ScanSchedule::volume_at(std::uint64_t sweep) const noexcept {
  const ScheduledScan& e = at(sweep);
  return e.first_volume + (sweep - e.first_sweep) / e.pattern->timing.sweeps_per_volume();
}

std::size_t ScanSchedule::retire_before(
    std::uint64_t sweep, std::array<const scan::ScanPattern*, kMaxEntries>& retired) noexcept {
  std::size_t drop = 0;
  while (drop + 1 < count_ && entries_[drop + 1].first_sweep <= sweep) ++drop;
  std::size_t out = 0;
  for (std::size_t i = 0; i < drop; ++i) {
    const scan::ScanPattern* p = entries_[i].pattern;
    bool used = false;
    for (std::size_t j = i + 1; j < count_; ++j) used = used || entries_[j].pattern == p;
    for (std::size_t k = 0; k < out; ++k) used = used || retired[k] == p;
    if (!used) retired[out++] = p;
  }
  for (std::size_t i = drop; i < count_; ++i) entries_[i - drop] = entries_[i];
  count_ -= drop;
  return out;
}

}  // namespace ioct::rt
