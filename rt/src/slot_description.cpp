#include "slot_description.hpp"

namespace ioct::rt {

std::uint32_t ring_status_flags(const hal::GroupInfo& info, std::uint32_t extra_status) noexcept {
  std::uint32_t flags = extra_status;
  if ((info.status & hal::kGroupOverrun) != 0) flags |= shm::kStatusOverrun;
  if ((info.status & hal::kGroupClockFault) != 0) flags |= shm::kStatusClockFault;
  if ((info.status & hal::kGroupMissedTriggers) != 0 || info.missed_sweeps != 0) {
    flags |= shm::kStatusMissedTriggers;
  }
  return flags;
}

void describe_group(shm::SlotHeader& header, const hal::GroupInfo& info, const GroupTimes& times,
                    const hal::DigitizerConfig& geometry, const ScheduledScan& scan,
                    std::uint32_t extra_status) noexcept {
  const scan::ScanPattern& pattern = *scan.pattern;
  const std::uint32_t bscans_per_volume = pattern.timing.bscans_per_volume;
  header.first_sweep_counter = info.first_sweep_counter;
  header.t_first_sweep_ns = times.first_sweep_ns;
  header.t_last_sweep_ns = times.last_sweep_ns;
  header.bscan_count = geometry.bscans_per_group;
  header.active_ascan_begin = pattern.active_begin;
  header.active_ascan_end = pattern.active_end;
  header.scan_pattern_id = pattern.pattern_id();
  header.scan_generation = scan.generation;
  header.status_flags = ring_status_flags(info, extra_status);
  header.missed_sweeps = info.missed_sweeps;
  header.reserved0 = 0;

  const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
  const std::uint64_t first_sweep =
      info.first_sweep_counter > scan.first_sweep ? info.first_sweep_counter : scan.first_sweep;
  const std::uint64_t first_bscan = (first_sweep - scan.first_sweep) / sweeps_per_bscan;
  for (std::uint32_t b = 0; b < header.bscans.size(); ++b) {
    shm::BscanMarker& marker = header.bscans[b];
    if (b >= geometry.bscans_per_group) {
      marker = shm::BscanMarker{};
      continue;
    }
    const std::uint64_t bscan = first_bscan + b;
    const std::uint32_t line = static_cast<std::uint32_t>(bscan % bscans_per_volume);
    const scan::BscanPlan& plan = pattern.bscans[line];
    marker.volume_index = scan.first_volume + bscan / bscans_per_volume;
    marker.bscan_in_volume = line;
    marker.flags = (line == 0 ? shm::kBscanVolumeStart : 0u) |
                   (line + 1 == bscans_per_volume ? shm::kBscanVolumeEnd : 0u) |
                   (plan.reversed ? shm::kBscanReversed : 0u);
    marker.galvo_start[0] = plan.start.x;
    marker.galvo_start[1] = plan.start.y;
    marker.galvo_end[0] = plan.end.x;
    marker.galvo_end[1] = plan.end.y;
  }
}

}  // namespace ioct::rt
